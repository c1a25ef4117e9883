// Every input the fuzzers ever crashed on (tests/fuzz/regressions/<target>/), and the
// seed corpus (fuzz/corpus/), through the scene loader with the project's own compiler:
// each must load, or be refused with twinray::Error(InvalidInput) and a message that
// names the file. Also built under the asan preset (CMakePresets.json).
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <twinray/core/error.hpp>
#include <twinray/scene/validate.hpp>
#include <twinray/io/obj_mesh.hpp>
#include <twinray/io/scene_json.hpp>

#include "fuzz_limits.hpp"

namespace fs = std::filesystem;

namespace {

std::vector<fs::path> inputs(const std::string& folder) {
  std::vector<fs::path> files;
  if (fs::is_directory(folder))
    for (const auto& e : fs::directory_iterator(folder))
      if (e.is_regular_file() && e.path().filename() != ".gitkeep") files.push_back(e.path());
  return files;
}

std::string read(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Under the fuzz targets' own limits (fuzz/fuzz_limits.hpp).
template <class T>
void load_scene(const std::string& text, const std::string& name) {
  const twinray::io::SceneLimits limits = fuzz::scene_limits();
  try {
    twinray::io::SceneFile<T> f =
        twinray::io::parse_scene<T>(text, name, TWINRAY_FUZZ_OBJ_DIR, limits);
    twinray::validate(f.camera);
    twinray::validate(f.scene);
    twinray::validate(f.options);
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    CHECK(std::string(e.what()).rfind(name + ":", 0) == 0);
  }
}

template <class T>
void load_obj(const std::string& text, const std::string& name) {
  const twinray::io::ObjLimits limits = fuzz::obj_limits();
  try {
    twinray::Mesh<T> mesh = twinray::io::parse_obj_mesh<T>(text, name, limits);
    for (const auto& tri : mesh.triangles)
      for (int index : tri) CHECK((index >= 0 && size_t(index) < mesh.vertices.size()));
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    CHECK(std::string(e.what()).rfind(name + ":", 0) == 0);
  }
}

}  // namespace

TEST_CASE("scene files the JSON fuzzer crashed on, and its seeds, load or are refused") {
  std::vector<fs::path> files = inputs(TWINRAY_FUZZ_REGRESSIONS_DIR "/scene_json");
  std::vector<fs::path> seeds = inputs(TWINRAY_FUZZ_CORPUS_DIR "/scene_json");
  REQUIRE(seeds.size() >= 5);
  files.insert(files.end(), seeds.begin(), seeds.end());
  for (const fs::path& p : files) {
    INFO(p.string());
    std::string text = read(p);
    load_scene<float>(text, p.filename().string());
    load_scene<double>(text, p.filename().string());
  }
}

TEST_CASE("OBJ files the OBJ fuzzer crashed on, and its seeds, load or are refused") {
  std::vector<fs::path> files = inputs(TWINRAY_FUZZ_REGRESSIONS_DIR "/obj_mesh");
  std::vector<fs::path> seeds = inputs(TWINRAY_FUZZ_CORPUS_DIR "/obj");
  REQUIRE(seeds.size() >= 5);
  files.insert(files.end(), seeds.begin(), seeds.end());
  for (const fs::path& p : files) {
    INFO(p.string());
    std::string text = read(p);
    load_obj<float>(text, p.filename().string());
    load_obj<double>(text, p.filename().string());
  }
}
