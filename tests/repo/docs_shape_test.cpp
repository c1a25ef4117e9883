// The docs say what is true now, in pages a reader can hold: line limits for the README,
// its headline figures, the changelog and every page under docs/, and no lab-notebook
// traces in them (run ordinals such as "the fifty-ninth run", commit ids in prose). The
// history of experiments lives in git.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kRoot = TWINRAY_SOURCE_DIR;

std::vector<std::string> lines_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

// The lines of a Markdown section: from its "## title" heading to the next heading of
// the same or a higher level; empty where there is no such section.
std::vector<std::string> section(const std::vector<std::string>& lines, const std::string& title) {
  std::vector<std::string> out;
  bool inside = false;
  for (const std::string& line : lines) {
    if (line.rfind("## ", 0) == 0 || line.rfind("# ", 0) == 0) {
      if (inside) break;
      inside = line == "## " + title;
    }
    if (inside) out.push_back(line);
  }
  return out;
}

// Run ordinals as a lab notebook writes them: "the fifty-ninth run", "the 12th runs",
// "the third to sixth runs". "first" and "second" are left out: "the first run of a
// process" is ordinary prose.
std::vector<std::string> run_ordinals(const std::string& text) {
  static const std::regex ordinal(
      R"((\b(third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth|[a-z]+teenth|[a-z]+tieth|(twenty|thirty|forty|fifty|sixty|seventy|eighty|ninety)-(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth))|\b[0-9]+(st|nd|rd|th))\s+(full\s+|interleaved\s+|benchmark\s+)?runs?\b)",
      std::regex::icase);
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), ordinal);
       it != std::sregex_iterator(); ++it)
    out.push_back(it->str());
  return out;
}

// Words that look like git commit ids, abbreviated (7 to 12 hex digits) or whole (40),
// with at least one letter and one digit: "d426cf6" matches; "4767956", "effaced" and
// a 16-digit hash in an error message quoted by the docs do not.
std::vector<std::string> commit_ids(const std::string& text) {
  static const std::regex hex(R"(\b[0-9a-f]{7,40}\b)");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), hex); it != std::sregex_iterator();
       ++it) {
    const std::string w = it->str();
    if ((w.size() <= 12 || w.size() == 40) && w.find_first_of("0123456789") != std::string::npos &&
        w.find_first_of("abcdef") != std::string::npos)
      out.push_back(w);
  }
  return out;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

// Every Markdown file a reader meets: the README, the changelog and docs/.
std::vector<fs::path> doc_pages() {
  std::vector<fs::path> out = {kRoot / "README.md", kRoot / "CHANGELOG.md"};
  for (const auto& entry : fs::directory_iterator(kRoot / "docs"))
    if (entry.path().extension() == ".md") out.push_back(entry.path());
  return out;
}

}  // namespace

TEST_CASE("docs shape: the patterns catch what they name and pass plain prose") {
  CHECK(run_ordinals("In the fifty-ninth run the mesh was ahead.").size() == 1);
  CHECK(run_ordinals("the fifty-seventh to sixtieth runs").size() == 1);
  CHECK(run_ordinals("the 12th run, the third runs").size() == 2);
  CHECK(run_ordinals("the first run of a process builds the program; a second run").empty());
  CHECK(run_ordinals("the third frame, the fifth column").empty());
  CHECK(commit_ids("measured at commit d426cf6 and 33b3b39").size() == 2);
  CHECK(commit_ids("1920x1080, 4767956 rays, the word effaced, 0x1fffu").empty());
  CHECK(commit_ids("the key aff4dd3548949c31-40-0-39-30").empty());
  const std::vector<std::string> page = {"# T", "## A", "a1", "### A.1", "a2", "## B", "b1"};
  CHECK(section(page, "A").size() == 4);
  CHECK(section(page, "B").size() == 2);
  CHECK(section(page, "C").empty());
}

TEST_CASE("docs shape: README, headline figures, changelog and docs pages within their limits") {
  const auto readme = lines_of(kRoot / "README.md");
  CHECK_MESSAGE(readme.size() <= 250, "README.md has " << readme.size() << " lines (at most 250)");
  const auto headline = section(readme, "Headline figures");
  CHECK_MESSAGE(!headline.empty(), "README.md has no \"## Headline figures\" section");
  CHECK_MESSAGE(headline.size() <= 25,
                "README.md's Headline figures have " << headline.size() << " lines (at most 25)");
  const auto changelog = lines_of(kRoot / "CHANGELOG.md");
  CHECK_MESSAGE(changelog.size() <= 200,
                "CHANGELOG.md has " << changelog.size() << " lines (at most 200)");
  int pages = 0;
  for (const auto& entry : fs::directory_iterator(kRoot / "docs")) {
    if (entry.path().extension() != ".md") continue;
    ++pages;
    const size_t n = lines_of(entry.path()).size();
    CHECK_MESSAGE(n <= 400, entry.path().filename().string()
                                << " has " << n << " lines (at most 400)");
  }
  CHECK(pages >= 10);
}

TEST_CASE("docs shape: no run ordinals in any doc, no commit ids in prose") {
  for (const fs::path& page : doc_pages()) {
    const std::string text = joined(lines_of(page));
    for (const std::string& hit : run_ordinals(text))
      FAIL_CHECK(page.filename().string() << ": a run ordinal, \"" << hit
                                          << "\" (say what is true now; history lives in git)");
    for (const std::string& hit : commit_ids(text))
      FAIL_CHECK(page.filename().string() << ": a commit id in prose, \"" << hit << "\"");
  }
}

TEST_CASE("docs shape: performance.md opens with today's table and the command that made it") {
  const auto page = lines_of(kRoot / "docs" / "performance.md");
  const auto glance = section(page, "At a glance");
  REQUIRE_MESSAGE(!glance.empty(), "docs/performance.md has no \"## At a glance\" section");
  // The first screen: the section starts within the page's first 15 lines and holds
  // the command that reproduces it and a table of ratios against Embree.
  size_t start = 0;
  while (start < page.size() && page[start] != "## At a glance") ++start;
  CHECK(start < 15);
  const std::string text = joined(glance);
  CHECK(text.find("twinray bench --against") != std::string::npos);
  CHECK(text.find("| scene |") != std::string::npos);
  CHECK(text.find("embree_bench") != std::string::npos);
}
