// write_file_atomically(): an output file is either complete or absent. The bytes go to
// a temporary file in the same folder, are flushed, and the temporary is renamed over
// the target; on any failure it is removed and the earlier file stays as it was.
#pragma once

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <twinray/core/error.hpp>
#include <twinray/core/process.hpp>

namespace twinray {
namespace io {

// The suffix of this process's temporary files: ".tmp-HOST-PID". Naming the host as
// well as the process lets processes on several hosts share a folder (a frames folder
// on a network file system): each can tell its own leftovers from another's work.
inline std::string temporary_suffix() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  return ".tmp-" + std::string(host) + "-" + std::to_string(::getpid());
}

// Whether a file name carries a temporary suffix (see above).
inline bool is_temporary(const std::string& name) {
  return name.find(".tmp-") != std::string::npos;
}

// Whether `name` is a temporary file that no running process will finish: one written
// on this host by a process that is gone. A temporary of another host, or of a
// process that still runs, is never taken for a leftover.
inline bool is_abandoned_temporary(const std::string& name) {
  const size_t at = name.rfind(".tmp-");
  const size_t dash = name.rfind('-');
  if (at == std::string::npos || dash == std::string::npos || dash < at + 5) return false;
  const std::string host = name.substr(at + 5, dash - at - 5);
  const std::string pid_text = name.substr(dash + 1);
  if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos)
    return false;
  char here[256] = {};
  if (::gethostname(here, sizeof here - 1) != 0 || host != here) return false;
  const long pid = std::strtol(pid_text.c_str(), nullptr, 10);
  return pid > 0 && !process_alive(pid);  // a zombie has ended too
}

// Throws Error(RuntimeFailure) "PATH: what: reason" (e.g. "No space left on device").
// Any thread may call it; the temporary is named after the host and the process, so
// two threads of one process must not write the same path at the same time.
inline void write_file_atomically(const std::string& path, const void* data, size_t size) {
  std::string tmp = path + temporary_suffix();
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
