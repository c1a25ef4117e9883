// The cost of starting cold: N fresh `twinray render` processes in a row, each timed
// from start to exit, with twinray's and PoCL's disk caches empty before the first
// (TWINRAY_CACHE_DIR and POCL_CACHE_DIR point at new, empty folders of each trial). The
// first process compiles what it renders with; what the later ones pay shows what it
// left in the caches. TWINRAY_OPENCL_KERNEL and TWINRAY_OPENCL_FIRST_FRAME are unset in
// the processes, so the backend's own choices are timed.
//
//   startup_bench [--twinray PATH] [--processes 4] [--trials 3] [-- RENDER ARGS...]
//
// RENDER ARGS default to `render demo --width 1920 --height 1080 --backend opencl`;
// `-o FOLDER/out.png` is added. Prints, per trial and process, the wall time, the CPU
// time (user + system, the process and its children: on a busy machine the wall time
// includes waiting for a core) and the kernel the summary line names; then the median
// of each process position over the trials.
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "bench_stats.hpp"

#ifndef TWINRAY_BENCH_CLI
#define TWINRAY_BENCH_CLI "twinray"
#endif

extern char** environ;

namespace {

struct Run {
  double wall_s = 0, cpu_s = 0;
  int status = -1;
  std::string kernel;  // "kernel X" of the summary line; "?" where none
};

// The environment of this process, TWINRAY_CACHE_DIR and POCL_CACHE_DIR set, the
// kernel choices unset.
std::vector<std::string> child_environment(const std::string& twinray_cache,
                                           const std::string& pocl_cache) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    const std::string entry = *e;
    const std::string name = entry.substr(0, entry.find('='));
    if (name == "TWINRAY_CACHE_DIR" || name == "POCL_CACHE_DIR" ||
        name == "TWINRAY_OPENCL_KERNEL" || name == "TWINRAY_OPENCL_FIRST_FRAME")
      continue;
    env.push_back(entry);
  }
  env.push_back("TWINRAY_CACHE_DIR=" + twinray_cache);
  env.push_back("POCL_CACHE_DIR=" + pocl_cache);
  return env;
}

std::vector<char*> c_strings(std::vector<std::string>& v) {
  std::vector<char*> out;
  for (std::string& s : v) out.push_back(&s[0]);
  out.push_back(nullptr);
  return out;
}

// Runs argv with env, stdout and stderr to `log`; times it.
Run run_process(std::vector<std::string> argv, std::vector<std::string> env,
                const std::string& log) {
  Run run;
  std::vector<char*> args = c_strings(argv), envp = c_strings(env);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid < 0) return run;
  if (pid == 0) {
    FILE* out = std::freopen(log.c_str(), "w", stdout);
    if (!out || dup2(fileno(stdout), 2) < 0) _exit(126);
    execve(args[0], args.data(), envp.data());
    _exit(127);
  }
  int status = 0;
  struct rusage usage {};
  if (wait4(pid, &status, 0, &usage) != pid) return run;
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + t.tv_usec * 1e-6; };
  run.cpu_s = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::ifstream f(log);
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t at = text.rfind("kernel ");
  run.kernel = "?";
  if (at != std::string::npos) {
    const size_t end = text.find_first_of(",\n ", at + 7);
    run.kernel = text.substr(at + 7, end == std::string::npos ? end : end - at - 7);
  }
  return run;
}

int usage(const char* why) {
  std::cerr << "startup_bench: " << why
            << "\nusage: startup_bench [--twinray PATH] [--processes N] [--trials N] "
               "[-- RENDER ARGS...]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string twinray = TWINRAY_BENCH_CLI;
  int processes = 4, trials = 3;
  std::vector<std::string> render = {"render",   "demo", "--width",   "1920",
                                     "--height", "1080", "--backend", "opencl"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--twinray" && has_value) {
      twinray = argv[++i];
    } else if (a == "--processes" && has_value) {
      processes = std::atoi(argv[++i]);
    } else if (a == "--trials" && has_value) {
      trials = std::atoi(argv[++i]);
    } else if (a == "--") {
      render.assign(argv + i + 1, argv + argc);
      break;
    } else {
      return usage(("unknown or incomplete option '" + a + "'").c_str());
    }
  }
  if (processes < 1 || trials < 1) return usage("--processes and --trials must be at least 1");
  if (access(twinray.c_str(), X_OK) != 0)
    return usage(("cannot run '" + twinray + "' (--twinray PATH)").c_str());

  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("twinray-startup-bench-" + std::to_string(getpid()));
  std::vector<std::vector<double>> wall(processes), cpu(processes);
  std::cout << "# " << twinray;
  for (const std::string& a : render) std::cout << " " << a;
  std::cout << "\ntrial,process,wall_s,cpu_s,kernel,exit\n";
  int failures = 0;
  for (int t = 0; t < trials; ++t) {
    const fs::path dir = root / ("trial" + std::to_string(t + 1));
    fs::remove_all(dir);
    fs::create_directories(dir / "twinray-cache");
    fs::create_directories(dir / "pocl-cache");
    const std::vector<std::string> env =
        child_environment((dir / "twinray-cache").string(), (dir / "pocl-cache").string());
    for (int p = 0; p < processes; ++p) {
      std::vector<std::string> args = {twinray};
      args.insert(args.end(), render.begin(), render.end());
      args.push_back("-o");
      args.push_back((dir / "out.png").string());
      const Run r = run_process(args, env, (dir / "log.txt").string());
      std::printf("%d,%d,%.3f,%.3f,%s,%d\n", t + 1, p + 1, r.wall_s, r.cpu_s, r.kernel.c_str(),
                  r.status);
      std::fflush(stdout);
      failures += r.status != 0;
      wall[p].push_back(r.wall_s);
      cpu[p].push_back(r.cpu_s);
    }
  }
  fs::remove_all(root);
  std::cout << "\nprocess,median_wall_s,median_cpu_s  (over " << trials << " trials)\n";
  for (int p = 0; p < processes; ++p)
    std::printf("%d,%.3f,%.3f\n", p + 1, twinray_bench::quantile(wall[p], 0.5),
                twinray_bench::quantile(cpu[p], 0.5));
  if (failures) std::cerr << "startup_bench: " << failures << " process(es) failed\n";
  return failures ? 1 : 0;
}
