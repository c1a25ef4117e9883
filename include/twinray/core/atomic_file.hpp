// try_write_file_atomically(): a file is either complete or absent. The bytes go to a
// temporary file in the same folder, are flushed, and the temporary is renamed over
// the target; on any failure it is removed and the earlier file stays as it was. The
// outputs (io/atomic_file.hpp, which throws) and the OpenCL program cache
// (backend/opencl/program.hpp, where a failure only costs the cache) both write so.
#pragma once

#include <cerrno>
#include <cstdlib>
#include <string>

#include <fcntl.h>
#include <unistd.h>

#include <twinray/core/process.hpp>

namespace twinray {

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

// How try_write_file_atomically() failed: what failed ("cannot write", "write failed"
// or "cannot replace the file") and errno's value then.
struct WriteFailure {
  const char* what = "";
  int error = 0;
};

// Writes `size` bytes from `data` to `path` through the temporary `path + suffix`:
// whole, or not at all. With `sync`, the bytes reach the disk (fsync) before the
// rename, so that the file is whole after a crash of the system as well; without, only
// a process that dies half-way is covered (enough for a cache that can be rebuilt).
// Whether it was written; where not, and `failure` is given, why. Two writers of one
// path at once need suffixes of their own.
inline bool try_write_file_atomically(const std::string& path, const void* data, size_t size,
                                      const std::string& suffix = temporary_suffix(),
                                      bool sync = true, WriteFailure* failure = nullptr) {
  const std::string tmp = path + suffix;
  auto fail = [&](const char* what, bool remove) {
    const int e = errno;
    if (remove) ::unlink(tmp.c_str());
    if (failure) *failure = WriteFailure{what, e};
    return false;
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) return fail("cannot write", false);
  const char* p = static_cast<const char*>(data);
  size_t left = size;
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd);
      errno = e;
      return fail("write failed", true);
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  if (sync && ::fsync(fd) != 0) {
    const int e = errno;
    ::close(fd);
    errno = e;
    return fail("write failed", true);
  }
  if (::close(fd) != 0) return fail("write failed", true);
  if (::rename(tmp.c_str(), path.c_str()) != 0) return fail("cannot replace the file", true);
  return true;
}

}  // namespace twinray
