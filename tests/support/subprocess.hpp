// Runs a program the way a user's shell would and captures what it says: the one
// subprocess helper of the tests of the real programs (tests/apps). POSIX only.
//
//   Result r = run({exe, "render", "demo", "-o", "x.png"}, {.cwd = dir});
//   Process p = Process::start(argv, options);  ...  ::kill(p.pid(), SIGINT);  p.finish();
//
// stdin is /dev/null; stdout and stderr go to temporary files (no pipe to fill), so any
// amount of output is fine. argv[0] without a '/' is looked up on PATH.
#pragma once

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <pty.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace test_support {

struct Result {
  // Exit status; 128 + signal when killed; -2 when it hung past the time-out (and was
  // killed); -1 when it could not be started or waited for.
  int status = -1;
  std::string out, err;
};

struct RunOptions {
  std::string cwd;                // empty: this process's
  std::vector<std::string> env;   // "NAME=value" sets or replaces, "NAME" removes
  long long max_file_bytes = -1;  // RLIMIT_FSIZE of the child (-1: unchanged)
  int timeout_s = 300;
};

inline std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Whether a program's output holds `part`.
inline bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

// The environment of this process with `edits` applied (see RunOptions::env).
inline std::vector<std::string> environment(const std::vector<std::string>& edits) {
  std::map<std::string, std::string> vars;
  for (char** e = environ; *e; ++e) {
    std::string s = *e;
    vars[s.substr(0, s.find('='))] = s;
  }
  for (const std::string& e : edits) {
    size_t eq = e.find('=');
    if (eq == std::string::npos)
      vars.erase(e);
    else
      vars[e.substr(0, eq)] = e;
  }
  std::vector<std::string> out;
  for (auto& v : vars) out.push_back(v.second);
  return out;
}

inline std::vector<char*> c_strings(std::vector<std::string>& v) {
  std::vector<char*> out;
  for (std::string& s : v) out.push_back(&s[0]);
  out.push_back(nullptr);
  return out;
}

// Waits for `pid` at most timeout_s seconds (then kills it: -2); the status as Result's.
inline int wait_status(pid_t pid, int timeout_s) {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  int status = 0;
  while (true) {
    pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) return -1;
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -2;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// A started program: signal it through pid(), collect it with finish().
class Process {
 public:
  static Process start(std::vector<std::string> argv, const RunOptions& options = {}) {
    static int counter = 0;
    Process p;
    p.timeout_s_ = options.timeout_s;
    std::string base = std::filesystem::temp_directory_path().string() + "/twinray-test-" +
                       std::to_string(::getpid()) + "-" + std::to_string(counter++);
    p.out_path_ = base + ".out";
    p.err_path_ = base + ".err";
    std::vector<std::string> envs = environment(options.env);
    std::vector<char*> c_argv = c_strings(argv), c_env = c_strings(envs);
    p.pid_ = ::fork();
    if (p.pid_ == 0) {
      if (!options.cwd.empty() && ::chdir(options.cwd.c_str()) != 0) ::_exit(125);
      if (options.max_file_bytes >= 0) {
        // A write past the limit then fails with EFBIG instead of killing the process.
        ::signal(SIGXFSZ, SIG_IGN);
        rlimit limit{static_cast<rlim_t>(options.max_file_bytes),
                     static_cast<rlim_t>(options.max_file_bytes)};
        ::setrlimit(RLIMIT_FSIZE, &limit);
      }
      int out = ::open(p.out_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      int err = ::open(p.err_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
      int in = ::open("/dev/null", O_RDONLY);
      if (out < 0 || err < 0 || in < 0) ::_exit(125);
      ::dup2(in, 0), ::dup2(out, 1), ::dup2(err, 2);
      ::execvpe(c_argv[0], c_argv.data(), c_env.data());
      ::_exit(127);
    }
    return p;
  }

  pid_t pid() const { return pid_; }

  // Waits for the program (killing it past the time-out) and returns what it said.
  Result finish() {
    Result r;
    r.status = pid_ < 0 ? -1 : wait_status(pid_, timeout_s_);
    r.out = read_file(out_path_);
    r.err = read_file(err_path_);
    std::remove(out_path_.c_str());
    std::remove(err_path_.c_str());
    pid_ = -1;
    return r;
  }

 private:
  pid_t pid_ = -1;
  int timeout_s_ = 300;
  std::string out_path_, err_path_;
};

// Runs argv to its end.
inline Result run(std::vector<std::string> argv, const RunOptions& options = {}) {
  return Process::start(std::move(argv), options).finish();
}

// Runs argv in `cwd` with environment edits.
inline Result run(std::vector<std::string> argv, const std::string& cwd,
                  const std::vector<std::string>& env = {}, int timeout_s = 300) {
  RunOptions o;
  o.cwd = cwd;
  o.env = env;
  o.timeout_s = timeout_s;
  return run(std::move(argv), o);
}

// Runs with stdin, stdout and stderr on a pseudo-terminal, as in an interactive shell;
// returns everything written to the terminal in `out`.
inline Result run_on_terminal(std::vector<std::string> argv, const std::string& cwd = "",
                              int timeout_s = 300) {
  std::vector<std::string> envs = environment({"TERM=xterm"});
  std::vector<char*> c_argv = c_strings(argv), c_env = c_strings(envs);
  int master = -1;
  winsize ws{};
  ws.ws_col = 100, ws.ws_row = 30;
  pid_t pid = ::forkpty(&master, nullptr, nullptr, &ws);
  if (pid == 0) {
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) ::_exit(125);
    ::execve(c_argv[0], c_argv.data(), c_env.data());
    ::_exit(127);
  }
  Result r;
  if (pid < 0) return r;
  // Read until the child closes the terminal (EIO), then collect its status.
  char buf[4096];
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    ssize_t n = ::read(master, buf, sizeof buf);
    if (n > 0) {
      r.out.append(buf, static_cast<size_t>(n));
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;
    }
  }
  ::close(master);
  r.status = wait_status(pid, 10);
  return r;
}

// A fresh, empty folder for one test.
inline std::string fresh_folder(const std::string& root, const std::string& name) {
  std::string dir = root + "/" + name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// The names in a folder, sorted.
inline std::vector<std::string> listing(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace test_support
