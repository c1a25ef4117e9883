// Runs a program the way a user's shell would and captures what it says: for tests of
// the real `twinray` command. POSIX only.
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
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace cli_test {

struct Result {
  int status = -1;  // exit status; 128 + signal when killed
  std::string out, err;
};

inline std::string read_file(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

inline void write_file(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

// The environment of this process with `overrides` ("NAME=value") replacing or adding.
inline std::vector<std::string> environment(const std::vector<std::string>& overrides) {
  std::map<std::string, std::string> vars;
  for (char** e = environ; *e; ++e) {
    std::string s = *e;
    vars[s.substr(0, s.find('='))] = s;
  }
  for (const std::string& o : overrides) vars[o.substr(0, o.find('='))] = o;
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
      return -2;  // hung
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// Runs argv[0] with argv in `cwd` (empty: this process's), env overrides as above.
// stdout and stderr go to files (no pipe to fill), so any amount of output is fine.
inline Result run(std::vector<std::string> argv, const std::string& cwd = "",
                  const std::vector<std::string>& env = {}, int timeout_s = 300) {
  static int counter = 0;
  std::string base = std::filesystem::temp_directory_path().string() + "/twinray-cli-test-" +
                     std::to_string(::getpid()) + "-" + std::to_string(counter++);
  std::string out_path = base + ".out", err_path = base + ".err";
  std::vector<std::string> envs = environment(env);
  std::vector<char*> c_argv = c_strings(argv), c_env = c_strings(envs);
  pid_t pid = ::fork();
  if (pid == 0) {
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) ::_exit(125);
    int out = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    int err = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    int in = ::open("/dev/null", O_RDONLY);
    if (out < 0 || err < 0 || in < 0) ::_exit(125);
    ::dup2(in, 0), ::dup2(out, 1), ::dup2(err, 2);
    ::execve(c_argv[0], c_argv.data(), c_env.data());
    ::_exit(127);
  }
  Result r;
  r.status = pid < 0 ? -1 : wait_status(pid, timeout_s);
  r.out = read_file(out_path);
  r.err = read_file(err_path);
  std::remove(out_path.c_str());
  std::remove(err_path.c_str());
  return r;
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

}  // namespace cli_test
