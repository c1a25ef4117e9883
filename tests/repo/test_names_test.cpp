// Every doctest case runs under CTest. doctest_discover_tests registers one CTest test
// per case and runs it with --test-case=NAME; a ';' in NAME is CMake's list separator,
// which splits the case into two tests that match nothing and pass without running.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// The names of the TEST_CASEs in `text` that CTest cannot run as written.
std::vector<std::string> unrunnable_names(const std::string& text) {
  static const std::regex test_case(R"re(TEST_CASE(?:_TEMPLATE)?\(\s*"([^"]*)")re");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), test_case);
       it != std::sregex_iterator(); ++it)
    if ((*it)[1].str().find(';') != std::string::npos) out.push_back((*it)[1].str());
  return out;
}

}  // namespace

TEST_CASE("test names: no test case under tests/ has a semicolon in its name") {
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(TWINRAY_SOURCE_DIR) / "tests")) {
    if (!e.is_regular_file() || e.path().extension() != ".cpp") continue;
    ++files;
    std::ifstream in(e.path(), std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    for (const std::string& name : unrunnable_names(text.str()))
      CHECK_MESSAGE(false, e.path().string() << ": \"" << name << "\"");
  }
  CHECK(files > 20);
}

TEST_CASE("test names: the check finds a semicolon on one line and across lines") {
  CHECK(unrunnable_names("TEST_CASE(\"a, b\") {}").empty());
  CHECK(unrunnable_names("TEST_CASE(\"a; b\") {}") == std::vector<std::string>{"a; b"});
  CHECK(unrunnable_names("TEST_CASE(\n    \"x; y\") {}") == std::vector<std::string>{"x; y"});
}
