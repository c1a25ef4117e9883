// What the library asks of the process and its host:
//  - process_alive(): whether a process of this host runs, for files that name the
//    process that owns them (temporary outputs, build locks);
//  - usable_memory_bytes(): the memory this process may fill, from which the loaders'
//    default limits follow (io/scene_json.hpp, io/obj_mesh.hpp);
//  - peak_resident_bytes(): the process's resident high-water mark.
#pragma once

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <iterator>
#include <string>

#include <signal.h>
#include <sys/resource.h>
#include <sys/types.h>
#include <unistd.h>

namespace twinray {

// Whether process `pid` runs: it exists (kill(pid, 0) succeeds, or fails only for want
// of permission) and is not a zombie, ended but not yet reaped: state Z in
// /proc/PID/stat, after the command name in parentheses. Where the state cannot be
// read, a process that exists counts as running.
inline bool process_alive(long pid) {
  if (pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) != 0 && errno != EPERM)) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');  // "PID (NAME) STATE ..."
  return paren == std::string::npos || paren + 2 >= text.size() || text[paren + 2] != 'Z';
}

// The memory this process may fill, in bytes: the machine's physical memory, or less
// where a control group (v2 memory.max, v1 memory.limit_in_bytes) or an address-space
// rlimit caps it. 0 when nothing can be read.
inline long long usable_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  long long bytes = pages > 0 && page > 0 ? static_cast<long long>(pages) * page : 0;
  auto cap = [&](long long limit) {
    if (limit > 0) bytes = bytes > 0 ? std::min(bytes, limit) : limit;
  };
  for (const char* file :
       {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream in(file);
    long long limit = 0;
    if (in >> limit) cap(limit);  // "max" (no limit) reads as nothing
  }
  struct rlimit as {};
  if (::getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY)
    cap(static_cast<long long>(as.rlim_cur));
  return bytes;
}

// The process's peak resident memory so far, in bytes (getrusage: ru_maxrss in KiB).
inline long long peak_resident_bytes() {
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<long long>(usage.ru_maxrss) * 1024;
}

}  // namespace twinray
