// write_file_atomically(): an output file is either complete or absent. The bytes go to
// a temporary file in the same folder, are flushed, and the temporary is renamed over
// the target; on any failure it is removed and the earlier file stays as it was.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include <twinray/core/error.hpp>

namespace twinray {
namespace io {

// Throws Error(RuntimeFailure) "PATH: what: reason" (e.g. "No space left on device").
// Any thread may call it; the temporary is named after the process, so two threads of
// one process must not write the same path at the same time.
inline void write_file_atomically(const std::string& path, const void* data, size_t size) {
  std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  auto fail = [&](const std::string& what) {
    int e = errno;
    ::unlink(tmp.c_str());
    throw Error(ErrorKind::RuntimeFailure, path + ": " + what + ": " + std::strerror(e));
  };
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) {
    int e = errno;
    throw Error(ErrorKind::RuntimeFailure, path + ": cannot write: " + std::strerror(e));
  }
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      ::close(fd);
      fail("write failed");
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("write failed");
  }
  if (::close(fd) != 0) fail("write failed");
  if (::rename(tmp.c_str(), path.c_str()) != 0) fail("cannot replace the file");
}

inline void write_file_atomically(const std::string& path,
                                  const std::vector<unsigned char>& bytes) {
  write_file_atomically(path, bytes.data(), bytes.size());
}

}  // namespace io
}  // namespace twinray
