// No comment in include/, apps/ or kernels/ carries a machine's measurement history: a
// comment says what the code does and why, and where a measured choice was measured
// (bench/, docs/performance.md); the runs themselves, their machines, their commits
// and their paired timings belong in docs/performance.md.
#include <doctest/doctest.h>

#include <cctype>
#include <filesystem>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "source_text.hpp"

namespace fs = std::filesystem;

namespace {

struct Pattern {
  const char* what;
  std::regex re;
};

// What a measurement log looks like in a comment.
const std::vector<Pattern>& history_patterns() {
  static const std::vector<Pattern> patterns = {
      {"an A/B comparison", std::regex(R"(A/B)")},
      {"a run ordinal",
       std::regex(R"(\b(eleventh|twelfth|[a-z]+teenth|[a-z]+tieth|[a-z]+ty-(first|second|third|)"
                  R"(fourth|fifth|sixth|seventh|eighth|ninth)|[0-9]{2,}(st|nd|rd|th)) runs?\b)",
                  std::regex::icase)},
      {"a commit id", std::regex(R"(\b[0-9a-f]{7,40}\b)")},
      {"a machine's name", std::regex(R"(\bZen ?[0-9]|\bXeon\b|\bEPYC\b)", std::regex::icase)},
      {"a timing ratio", std::regex(R"([0-9]\.[0-9]+ of the (frame|time)\b)")},
  };
  return patterns;
}

// A run of hex digits is a commit id only with a digit and a letter in it: words such
// as "defaced" and numbers such as 1048576 are not.
bool commit_like(const std::string& word) {
  bool digit = false, letter = false;
  for (char c : word) (std::isdigit(static_cast<unsigned char>(c)) ? digit : letter) = true;
  return digit && letter;
}

// "what: the comment line" for each line of `comments` that matches a pattern.
std::vector<std::string> history_in(const std::string& comments) {
  std::vector<std::string> found;
  std::istringstream in(comments);
  for (std::string line; std::getline(in, line);)
    for (const Pattern& p : history_patterns())
      for (auto it = std::sregex_iterator(line.begin(), line.end(), p.re);
           it != std::sregex_iterator(); ++it) {
        if (std::string(p.what) == "a commit id" && !commit_like(it->str())) continue;
        found.push_back(std::string(p.what) + " (" + it->str() + "):" + line);
        break;
      }
  return found;
}

}  // namespace

TEST_CASE("comment history: no comment in include, apps or kernels names a machine's A/B runs") {
  const fs::path root = TWINRAY_SOURCE_DIR;
  const std::set<std::string> extensions = {".h", ".hpp", ".cpp", ".cl", ".cmake"};
  int files = 0;
  for (const char* folder : {"include", "apps", "kernels"})
    for (const auto& e : fs::recursive_directory_iterator(root / folder)) {
      if (!e.is_regular_file()) continue;
      if (!extensions.count(e.path().extension().string()) &&
          e.path().filename() != "CMakeLists.txt")
        continue;
      ++files;
      for (const std::string& hit : history_in(repo_text::comments_of(e.path())))
        CHECK_MESSAGE(false, fs::relative(e.path(), root).generic_string() << ": " << hit);
    }
  CHECK(files > 50);
}

TEST_CASE("comment history: the patterns find each kind of log and pass plain comments") {
  // The examples are put together here from pieces, so that no comment holds them.
  const std::string ab = std::string("A/") + "B";
  CHECK(history_in(" paired " + ab + ", same bits\n").size() == 1);
  CHECK(history_in(" the fifty-" + std::string("ninth run") + " measured it\n").size() == 1);
  CHECK(history_in(" the sixtieth " + std::string("run") + "\n").size() == 1);
  CHECK(history_in(" commit " + std::string("f40d12f") + " built it\n").size() == 1);
  CHECK(history_in(" on a " + std::string("Zen") + " 4 class " + "EP" + "YC\n").size() == 1);
  CHECK(history_in(" on an Intel " + std::string("Xe") + "on\n").size() == 1);
  CHECK(history_in(" frames took 0.9" + std::string("3 of the time") + "\n").size() == 1);
  // Plain comments: numbers, hex-free words, a first run, a measurement's place.
  CHECK(history_in(" 1048576 primitives, a defaced box, 0x1p-30 of the area\n").empty());
  CHECK(history_in(" the first run compiles the program (docs/performance.md)\n").empty());
  CHECK(
      history_in(" Measured: costs 1-4 (bench/twinray_bench.cpp, docs/performance.md)\n").empty());
}
