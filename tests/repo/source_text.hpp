// Reading the tree's files for the repository checks: a file's text, and the text of
// its comments alone (links_test.cpp, comment_history_test.cpp).
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace repo_text {

inline std::string read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The comments of a source file: // and /* */ in C-like files, # in CMake and shell.
inline std::string comments_of(const std::filesystem::path& p) {
  const std::string text = read(p);
  const std::string ext = p.extension().string();
  std::string out;
  if (ext == ".cmake" || ext == ".sh" || ext == ".txt" || p.filename() == "run") {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      size_t hash = line.find('#');
      if (hash != std::string::npos) out += line.substr(hash + 1) + "\n";
    }
    return out;
  }
  for (size_t i = 0; i < text.size(); ++i) {
    if (text.compare(i, 2, "//") == 0) {
      size_t end = text.find('\n', i);
      out += text.substr(i + 2, end == std::string::npos ? std::string::npos : end - i - 2) + "\n";
      i = end == std::string::npos ? text.size() : end;
    } else if (text.compare(i, 2, "/*") == 0) {
      size_t end = text.find("*/", i + 2);
      out += text.substr(i + 2, end == std::string::npos ? std::string::npos : end - i - 2) + "\n";
      i = end == std::string::npos ? text.size() : end + 1;
    } else if (text[i] == '"') {  // skip string literals: "//" inside them is no comment
      for (++i; i < text.size() && text[i] != '"' && text[i] != '\n'; ++i)
        if (text[i] == '\\') ++i;
    }
  }
  return out;
}

}  // namespace repo_text
