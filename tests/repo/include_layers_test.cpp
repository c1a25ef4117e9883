// The include rule of docs/architecture.md: the folders of include/twinray/ are layers,
// and a header includes only headers of its own layer or of the layers below it,
// with no cycle anywhere:
//
//   device  <  core  <  scene  <  pack  <  backend  <  io
//
// generated/ (the kernel text embedded at build time) belongs to device; the umbrella
// twinray.hpp and version.hpp sit at the backend and core layers.
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// Header path relative to include/ ("twinray/core/error.hpp") -> its includes, resolved
// to the same form; includes of other libraries are left out.
using Graph = std::map<std::string, std::vector<std::string>>;

int layer_of(const std::string& header) {
  static const std::vector<std::pair<std::string, int>> layers = {
      {"twinray/device/", 0},     {"twinray/generated/", 0},  {"twinray/core/", 1},
      {"twinray/version.hpp", 1}, {"twinray/scene/", 2},      {"twinray/pack/", 3},
      {"twinray/backend/", 4},    {"twinray/twinray.hpp", 4}, {"twinray/io/", 5}};
  for (const auto& [prefix, layer] : layers)
    if (header.rfind(prefix, 0) == 0) return layer;
  return -1;
}

const char* layer_name(int layer) {
  static const char* names[] = {"device", "core", "scene", "pack", "backend", "io"};
  return layer >= 0 && layer < 6 ? names[layer] : "no layer";
}

// Every include that goes up a layer, every header outside the layers, and every
// cycle, as messages.
std::vector<std::string> violations(const Graph& graph) {
  std::vector<std::string> out;
  for (const auto& [header, includes] : graph) {
    const int from = layer_of(header);
    if (from < 0) out.push_back(header + " is in no layer");
    for (const std::string& inc : includes) {
      const int to = layer_of(inc);
      if (to > from)
        out.push_back(header + " (" + layer_name(from) + ") includes " + inc + " (" +
                      layer_name(to) + "), a layer above it");
    }
  }
  // Cycles: depth-first search, white / grey / black.
  std::map<std::string, int> state;
  std::vector<std::string> stack;
  std::set<std::string> reported;
  std::function<void(const std::string&)> visit = [&](const std::string& h) {
    state[h] = 1;
    stack.push_back(h);
    auto it = graph.find(h);
    if (it != graph.end())
      for (const std::string& next : it->second) {
        if (state[next] == 1) {
          std::string cycle;
          auto begin = std::find(stack.begin(), stack.end(), next);
          for (auto i = begin; i != stack.end(); ++i) cycle += *i + " -> ";
          if (reported.insert(next).second) out.push_back("include cycle: " + cycle + next);
        } else if (state[next] == 0) {
          visit(next);
        }
      }
    stack.pop_back();
    state[h] = 2;
  };
  for (const auto& entry : graph)
    if (state[entry.first] == 0) visit(entry.first);
  return out;
}

// The include graph of the headers under `include_dir`.
Graph read_graph(const fs::path& include_dir) {
  Graph graph;
  const std::regex include_line(R"(^\s*#\s*include\s*([<"])([^>"]+)[>"])");
  for (const auto& entry : fs::recursive_directory_iterator(include_dir / "twinray")) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = entry.path().extension().string();
    if (ext != ".h" && ext != ".hpp") continue;
    const std::string header = fs::relative(entry.path(), include_dir).generic_string();
    std::vector<std::string>& includes = graph[header];
    std::ifstream in(entry.path());
    for (std::string line; std::getline(in, line);) {
      std::smatch m;
      if (!std::regex_search(line, m, include_line)) continue;
      std::string target = m[2].str();
      // "adaptive.h" next to the including file (the device headers), or <twinray/...>.
      if (m[1].str() == "\"" && target.rfind("twinray/", 0) != 0)
        target = (fs::path(header).parent_path() / target).lexically_normal().generic_string();
      if (target.rfind("twinray/", 0) == 0) includes.push_back(target);
    }
  }
  return graph;
}

}  // namespace

TEST_CASE("include layers: every header of include/twinray includes only its layer or below") {
  Graph graph = read_graph(fs::path(TWINRAY_SOURCE_DIR) / "include");
  REQUIRE(graph.size() > 40);
  REQUIRE(graph.count("twinray/device/types.h") == 1);
  REQUIRE(graph.count("twinray/backend/backend.hpp") == 1);
  std::vector<std::string> found = violations(graph);
  for (const std::string& v : found) MESSAGE(v);
  CHECK(found.empty());
}

TEST_CASE("include layers: an upward include and a cycle are reported") {
  Graph up = {{"twinray/core/image.hpp", {"twinray/backend/cpu.hpp"}},
              {"twinray/backend/cpu.hpp", {}}};
  std::vector<std::string> v = violations(up);
  REQUIRE(v.size() == 1);
  CHECK(v[0].find("a layer above it") != std::string::npos);

  Graph cycle = {{"twinray/io/a.hpp", {"twinray/io/b.hpp"}},
                 {"twinray/io/b.hpp", {"twinray/io/c.hpp"}},
                 {"twinray/io/c.hpp", {"twinray/io/a.hpp"}}};
  v = violations(cycle);
  REQUIRE(v.size() == 1);
  CHECK(v[0].find("include cycle") != std::string::npos);

  Graph stray = {{"twinray/misc/x.hpp", {}}};
  CHECK(violations(stray).size() == 1);

  Graph fine = {{"twinray/io/png.hpp", {"twinray/core/image.hpp", "twinray/io/atomic_file.hpp"}},
                {"twinray/io/atomic_file.hpp", {"twinray/core/error.hpp"}},
                {"twinray/core/image.hpp", {}},
                {"twinray/core/error.hpp", {}}};
  CHECK(violations(fine).empty());
}
