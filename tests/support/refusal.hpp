// What the tests of refusals and files share: the message of the InvalidInput error a
// call throws, and a temporary folder removed when the test ends.
#pragma once

#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include <unistd.h>

#include <twinray/core/error.hpp>

namespace test_support {

// The message of the twinray::Error(InvalidInput) `f` throws; a failed check and ""
// when it throws none.
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    return e.what();
  }
  FAIL_CHECK("no error thrown");
  return "";
}

// A fresh folder under the system's temporary folder, removed with its contents.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& prefix) {
    path = std::filesystem::temp_directory_path() / (prefix + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string str() const { return path.string(); }
};

}  // namespace test_support
