// Runs a program as a user's shell would, with environment changes and resource limits,
// and captures its exit status, stdout and stderr: for the failure-path tests of the
// real `twinray` command. POSIX only.
#pragma once

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace failure_test {

struct Child {
  int status = -1;  // exit status; 128 + signal when killed; -2 when it hung
  std::string out, err;
};

struct ChildOptions {
  // "NAME=value" sets a variable, "NAME" (no '=') removes it.
  std::vector<std::string> env;
  long long max_file_bytes = -1;  // RLIMIT_FSIZE for the child (-1: unchanged)
  int timeout_s = 120;
};

inline std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Runs argv[0] with argv; stdout and stderr go through files in `scratch` (a folder).
inline Child run(const std::vector<std::string>& argv, const std::string& scratch,
                 const ChildOptions& options = {}) {
  const std::string out_path = scratch + "/child.stdout", err_path = scratch + "/child.stderr";
  pid_t pid = ::fork();
  if (pid == 0) {
    for (const std::string& e : options.env) {
      size_t eq = e.find('=');
      if (eq == std::string::npos)
        ::unsetenv(e.c_str());
      else
        ::setenv(e.substr(0, eq).c_str(), e.substr(eq + 1).c_str(), 1);
    }
    if (options.max_file_bytes >= 0) {
      // A write past the limit then fails with EFBIG instead of killing the process.
      ::signal(SIGXFSZ, SIG_IGN);
      rlimit limit{static_cast<rlim_t>(options.max_file_bytes),
                   static_cast<rlim_t>(options.max_file_bytes)};
      ::setrlimit(RLIMIT_FSIZE, &limit);
    }
    int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out < 0 || err < 0) ::_exit(126);
    ::dup2(out, STDOUT_FILENO);
    ::dup2(err, STDERR_FILENO);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  Child result;
  if (pid < 0) return result;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(options.timeout_s);
  int status = 0;
  while (true) {
    pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) return result;
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      result.status = -2;
      return result;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (WIFEXITED(status)) result.status = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) result.status = 128 + WTERMSIG(status);
  result.out = slurp(out_path);
  result.err = slurp(err_path);
  return result;
}

}  // namespace failure_test
