// read_small_file(): a whole regular file into memory, its size checked against a
// limit before anything is read (checked_file_size()). The scene, OBJ, MTL and texture
// loaders all check files through it, so each names the file and what it should have
// been in the same words.
#pragma once

#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>

#include <sys/stat.h>

#include <twinray/core/error.hpp>

namespace twinray {
namespace io {

namespace detail {

// The size of a regular file, checked against `max_bytes` before anything is read;
// `what` names the kind of file in messages ("an OBJ file").
inline long long checked_file_size(const std::string& path, long long max_bytes,
                                   const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    int e = errno;
    throw invalid_input(path + ": cannot open " + what + ": " + std::strerror(e));
  }
  if (S_ISDIR(st.st_mode)) throw invalid_input(path + ": is a folder, not " + what);
  if (!S_ISREG(st.st_mode)) throw invalid_input(path + ": is not a regular file");
  if (st.st_size > max_bytes)
    throw invalid_input(path + ": " + what + " is " + std::to_string(st.st_size) +
                        " bytes, more than the limit of " + std::to_string(max_bytes));
  return static_cast<long long>(st.st_size);
}

// Reads a whole regular file of at most `max_bytes`; the size is checked first.
inline std::string read_small_file(const std::string& path, long long max_bytes,
                                   const std::string& what) {
  const long long size = checked_file_size(path, max_bytes, what);
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    int e = errno;
    throw invalid_input(path + ": cannot open " + what + ": " + std::strerror(e));
  }
  std::string text(static_cast<size_t>(size), '\0');
  if (!text.empty() && !f.read(&text[0], static_cast<std::streamsize>(text.size())))
    throw invalid_input(path + ": cannot read " + what);
  return text;
}

}  // namespace detail

}  // namespace io
}  // namespace twinray
