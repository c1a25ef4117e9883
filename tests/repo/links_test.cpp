// Every relative link in the Markdown files, and every repository path named in
// Markdown or in a comment of the code, exists in the tree.
//
// A repository path is a word that starts with a top-level folder of the repository
// (include/, apps/, docs/, tests/, ...) or, in the code, with a folder of
// include/twinray/ (device/, core/, scene/, pack/, backend/, io/), which comments use
// for short. Only the part made of path characters counts: `tests/fuzz/<target>/`
// checks tests/fuzz/. Paths under build folders and the generated kernel header are
// made at build time and are not checked.
#include <doctest/doctest.h>

#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "source_text.hpp"

namespace fs = std::filesystem;

namespace {

using repo_text::comments_of;
using repo_text::read;

const fs::path kRoot = TWINRAY_SOURCE_DIR;

const std::vector<std::string> kTopFolders = {"include", "apps",  "examples", "bench",
                                              "docs",    "tests", "kernels",  "cmake",
                                              "scripts", "fuzz",  ".ci"};
const std::vector<std::string> kLibraryFolders = {"device", "core",    "scene",
                                                  "pack",   "backend", "io"};

bool skipped_dir(const fs::path& p) {
  const std::string name = p.filename().string();
  return name == ".git" || name.rfind("build", 0) == 0 || name == "out" || name == "regressions" ||
         name == "corpus";
}

std::vector<fs::path> files_of(const std::set<std::string>& extensions,
                               const std::set<std::string>& names = {}) {
  std::vector<fs::path> out;
  for (auto it = fs::recursive_directory_iterator(kRoot); it != fs::recursive_directory_iterator();
       ++it) {
    if (it->is_directory() && skipped_dir(it->path())) {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file()) continue;
    if (extensions.count(it->path().extension().string()) ||
        names.count(it->path().filename().string()))
      out.push_back(it->path());
  }
  return out;
}

// The repository paths named in `text`, as written.
std::vector<std::string> repository_paths(const std::string& text, bool short_forms) {
  static const std::regex word(R"([A-Za-z0-9_.\-/]+)");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), word); it != std::sregex_iterator();
       ++it) {
    std::string w = it->str();
    // Trailing sentence punctuation is not part of a path.
    while (!w.empty() && (w.back() == '.' || w.back() == ',' || w.back() == '-')) w.pop_back();
    const size_t slash = w.find('/');
    if (slash == std::string::npos || slash == 0) continue;
    // The word must start where a path can start (not inside a URL or another path).
    const size_t at = static_cast<size_t>(it->position());
    if (at > 0 && (text[at - 1] == ':' || text[at - 1] == '/' || text[at - 1] == '~' ||
                   text[at - 1] == '$' || text[at - 1] == '{'))
      continue;
    const std::string head = w.substr(0, slash);
    bool top = std::find(kTopFolders.begin(), kTopFolders.end(), head) != kTopFolders.end();
    bool lib = short_forms && std::find(kLibraryFolders.begin(), kLibraryFolders.end(), head) !=
                                  kLibraryFolders.end();
    if (!top && !lib) continue;
    if (w.find("generated/") != std::string::npos) continue;
    out.push_back(w);
  }
  return out;
}

bool exists_in_repo(const std::string& path, const fs::path& from_dir, bool short_forms) {
  if (fs::exists(kRoot / path)) return true;
  if (short_forms && fs::exists(kRoot / "include" / "twinray" / path)) return true;
  if (fs::exists(from_dir / path)) return true;
  return false;
}

// Relative link targets of a Markdown text: [text](target) and <img src="target">.
std::vector<std::string> markdown_links(const std::string& text) {
  static const std::regex link(R"(\]\(([^)\s]+)\)|src="([^"]+)\")");
  std::vector<std::string> out;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), link); it != std::sregex_iterator();
       ++it) {
    std::string target = (*it)[1].matched ? (*it)[1].str() : (*it)[2].str();
    if (target.rfind("http://", 0) == 0 || target.rfind("https://", 0) == 0 ||
        target.rfind("mailto:", 0) == 0 || target[0] == '#')
      continue;
    const size_t hash = target.find('#');
    if (hash != std::string::npos) target = target.substr(0, hash);
    out.push_back(target);
  }
  return out;
}

}  // namespace

TEST_CASE("links: every relative link in the Markdown files exists") {
  std::vector<fs::path> docs = files_of({".md"});
  REQUIRE(docs.size() >= 5);
  int checked = 0;
  for (const fs::path& md : docs)
    for (const std::string& target : markdown_links(read(md))) {
      ++checked;
      INFO(fs::relative(md, kRoot).string() << " links to " << target);
      CHECK(fs::exists(md.parent_path() / target));
    }
  CHECK(checked > 10);
}

TEST_CASE("links: every repository path named in Markdown exists") {
  for (const fs::path& md : files_of({".md"}))
    for (const std::string& path : repository_paths(read(md), false)) {
      INFO(fs::relative(md, kRoot).string() << " names " << path);
      CHECK(exists_in_repo(path, md.parent_path(), false));
    }
}

TEST_CASE("links: every repository path named in a comment of the code exists") {
  std::vector<fs::path> sources =
      files_of({".hpp", ".h", ".cpp", ".cl", ".cmake", ".sh"}, {"CMakeLists.txt", "run"});
  REQUIRE(sources.size() > 50);
  for (const fs::path& src : sources)
    for (const std::string& path : repository_paths(comments_of(src), true)) {
      INFO(fs::relative(src, kRoot).string() << " names " << path);
      CHECK(exists_in_repo(path, src.parent_path(), true));
    }
}

TEST_CASE("links: the checks find what is missing") {
  // Pages that do not exist, put together here so that this file names none of them.
  const std::string none = std::string("docs") + "/none.md", x = std::string("docs") + "/x.md";
  CHECK(markdown_links("see [the spec](" + none + "#keys) and [web](https://x.org)") ==
        std::vector<std::string>{none});
  std::vector<std::string> named =
      repository_paths("as io/scene_json.hpp says; tests/fuzz/<target>/ and " + x + ".", true);
  CHECK(named == std::vector<std::string>{"io/scene_json.hpp", "tests/fuzz/", x});
  CHECK(exists_in_repo("io/scene_json.hpp", kRoot, true));
  CHECK_FALSE(exists_in_repo(x, kRoot, true));
  CHECK(repository_paths("https://github.com/a/docs/b.md", false).empty());
  CHECK(comments_of(kRoot / "include" / "twinray" / "core" / "error.hpp").find("#pragma") ==
        std::string::npos);
}

TEST_CASE("links: no file names issue numbers of the work plan") {
  static const std::regex issue(R"(\bissues? #?[0-9]+\b)", std::regex::icase);
  for (const fs::path& f :
       files_of({".md", ".hpp", ".h", ".cpp", ".cl", ".cmake", ".sh", ".txt"}, {"run"})) {
    const std::string text = read(f);
    INFO(fs::relative(f, kRoot).string());
    CHECK_FALSE(std::regex_search(text, issue));
  }
}
