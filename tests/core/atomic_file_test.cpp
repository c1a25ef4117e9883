// Whole-or-nothing file writes (core/atomic_file.hpp), which the outputs and the OpenCL
// program cache share.
#include <doctest/doctest.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <twinray/core/atomic_file.hpp>

#include "support/refusal.hpp"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

}  // namespace

TEST_CASE("an atomic write replaces the file whole and leaves no temporary") {
  test_support::TempDir dir("twinray-atomic-test");
  const fs::path file = dir.path / "entry.bin";
  const std::string first(100000, 'a'), second = "short";
  for (bool sync : {true, false}) {
    CAPTURE(sync);
    CHECK(twinray::try_write_file_atomically(file.string(), first.data(), first.size(),
                                             twinray::temporary_suffix(), sync));
    CHECK(slurp(file) == first);
    CHECK(twinray::try_write_file_atomically(file.string(), second.data(), second.size(),
                                             ".tmp-own-suffix", sync));
    CHECK(slurp(file) == second);
    CHECK(twinray::try_write_file_atomically(file.string(), "", 0));  // an empty marker
    CHECK(slurp(file).empty());
    CHECK(names_in(dir.path) == std::vector<std::string>{"entry.bin"});
  }
}

TEST_CASE("a failed atomic write says why, keeps the earlier file and leaves no temporary") {
  test_support::TempDir dir("twinray-atomic-test");
  const fs::path file = dir.path / "entry.bin";
  REQUIRE(twinray::try_write_file_atomically(file.string(), "kept", 4));
  // A folder that is not there: the temporary cannot be made.
  twinray::WriteFailure failure;
  CHECK_FALSE(twinray::try_write_file_atomically((dir.path / "gone" / "x").string(), "new", 3,
                                                 twinray::temporary_suffix(), true, &failure));
  CHECK(std::string(failure.what) == "cannot write");
  CHECK(failure.error == ENOENT);
  // A folder where the file should go: written, but the rename fails; the temporary goes.
  const fs::path folder = dir.path / "folder";
  fs::create_directories(folder / "inside");
  failure = {};
  CHECK_FALSE(twinray::try_write_file_atomically(folder.string(), "new", 3,
                                                 twinray::temporary_suffix(), false, &failure));
  CHECK(std::string(failure.what) == "cannot replace the file");
  CHECK(failure.error != 0);
  CHECK(fs::is_directory(folder / "inside"));
  CHECK(slurp(file) == "kept");
  std::vector<std::string> names = names_in(dir.path);
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"entry.bin", "folder"});
}

TEST_CASE("temporaries are named after the host and the process, and told apart") {
  const std::string suffix = twinray::temporary_suffix();
  CHECK(suffix.rfind(".tmp-", 0) == 0);
  CHECK(suffix.substr(suffix.rfind('-') + 1) == std::to_string(::getpid()));
  CHECK(twinray::is_temporary("frame.png" + suffix));
  CHECK_FALSE(twinray::is_temporary("frame.png"));
  CHECK_FALSE(twinray::is_abandoned_temporary("frame.png" + suffix));  // this process runs
}
