// process_alive(): whether a process of this host runs, for files that name the
// process that owns them (temporary outputs, build locks).
#pragma once

#include <cerrno>
#include <fstream>
#include <iterator>
#include <string>

#include <signal.h>
#include <sys/types.h>

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

}  // namespace twinray
