// The cost of starting cold: N fresh `twinray render` processes in a row, each timed
// from start to exit, with twinray's and PoCL's disk caches empty before the first
// (TWINRAY_CACHE_DIR and POCL_CACHE_DIR point at new, empty folders of each trial). The
// first process compiles what it renders with; what the later ones pay shows what it
// left in the caches. TWINRAY_OPENCL_KERNEL, TWINRAY_OPENCL_FIRST_FRAME and
// TWINRAY_OPENCL_BACKGROUND_BUILD are unset in the processes, so the backend's own
// choices are timed.
//
//   startup_bench [--twinray PATH] [--processes 4] [--trials 3] [--between now|wait|both]
//                 [-- RENDER ARGS...]
//
// RENDER ARGS default to `render demo --width 1920 --height 1080 --backend opencl`;
// `-o FOLDER/out.png` is added. --between says what happens between two processes:
// `now`, the next starts at once, beside a background build the last one left (a user
// who renders again at once); `wait`, the next starts once no build lock is left in
// the twinray cache folder (the background build is done), the build helper's CPU time
// sampled from /proc meanwhile; `both` (the default) runs each trial both ways. Each
// trial ends once no build lock is left. Prints, per trial, mode and process, the wall
// time, the CPU time (user + system, the process and the children it waited for: on a
// busy machine the wall time includes waiting for a core), the CPU time of the
// background build it started (`wait` only; detached, so not in its own) and the
// kernel the summary line names; then the median of each over the trials.
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
#include <map>
#include <sstream>
#include <string>
#include <thread>
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
        name == "TWINRAY_OPENCL_KERNEL" || name == "TWINRAY_OPENCL_FIRST_FRAME" ||
        name == "TWINRAY_OPENCL_BACKGROUND_BUILD")
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
  // Nothing buffered for the child to write out again when it reopens stdout.
  std::cout.flush();
  std::fflush(stdout);
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

// The build lock files in twinray's cache folder `cache` (program-KEY.lock).
std::vector<std::string> build_locks(const std::string& cache) {
  std::vector<std::string> locks;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(cache, ec))
    if (e.path().extension() == ".lock") locks.push_back(e.path().string());
  return locks;
}

// The CPU time (user + system) process `pid` has used so far; 0 where it cannot be read.
double process_cpu_s(long pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');  // "PID (NAME) STATE ..."; utime, stime: 14, 15
  if (paren == std::string::npos) return 0;
  std::istringstream fields(text.substr(paren + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && fields >> field; ++i)
    if (i >= 14) ticks += std::atof(field.c_str());
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// Waits, at most ten minutes, until no build lock is left in `cache`; the CPU time of
// the build processes the locks named, as last seen (sampled every 10 ms).
double wait_for_builds(const std::string& cache) {
  std::map<long, double> cpu;
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const std::vector<std::string> locks = build_locks(cache);
    if (locks.empty() || std::chrono::steady_clock::now() - start > std::chrono::minutes(10)) break;
    for (const std::string& lock : locks) {
      std::ifstream f(lock);
      long pid = 0;
      if (f >> pid && pid > 0) cpu[pid] = std::max(cpu[pid], process_cpu_s(pid));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  double total = 0;
  for (const auto& p : cpu) total += p.second;
  return total;
}

int usage(const char* why) {
  std::cerr << "startup_bench: " << why
            << "\nusage: startup_bench [--twinray PATH] [--processes N] [--trials N] "
               "[--between now|wait|both] [-- RENDER ARGS...]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string twinray = TWINRAY_BENCH_CLI;
  int processes = 4, trials = 3;
  std::string between = "both";
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
    } else if (a == "--between" && has_value) {
      between = argv[++i];
    } else if (a == "--") {
      render.assign(argv + i + 1, argv + argc);
      break;
    } else {
      return usage(("unknown or incomplete option '" + a + "'").c_str());
    }
  }
  if (processes < 1 || trials < 1) return usage("--processes and --trials must be at least 1");
  if (between != "now" && between != "wait" && between != "both")
    return usage(("--between must be now, wait or both, not '" + between + "'").c_str());
  std::vector<std::string> modes;
  if (between != "wait") modes.push_back("now");
  if (between != "now") modes.push_back("wait");
  if (access(twinray.c_str(), X_OK) != 0)
    return usage(("cannot run '" + twinray + "' (--twinray PATH)").c_str());

  namespace fs = std::filesystem;
  const fs::path root =
      fs::temp_directory_path() / ("twinray-startup-bench-" + std::to_string(getpid()));
  // Per mode and process position, over the trials.
  std::map<std::string, std::vector<std::vector<double>>> wall, cpu, helper_cpu;
  for (const std::string& m : modes) {
    wall[m].resize(processes);
    cpu[m].resize(processes);
    helper_cpu[m].resize(processes);
  }
  std::cout << "# " << twinray;
  for (const std::string& a : render) std::cout << " " << a;
  std::cout << "\ntrial,mode,process,wall_s,cpu_s,helper_cpu_s,kernel,exit\n";
  int failures = 0;
  for (int t = 0; t < trials; ++t) {
    for (const std::string& mode : modes) {
      const fs::path dir = root / ("trial" + std::to_string(t + 1) + "-" + mode);
      const std::string cache = (dir / "twinray-cache").string();
      fs::remove_all(dir);
      fs::create_directories(cache);
      fs::create_directories(dir / "pocl-cache");
      const std::vector<std::string> env = child_environment(cache, (dir / "pocl-cache").string());
      for (int p = 0; p < processes; ++p) {
        std::vector<std::string> args = {twinray};
        args.insert(args.end(), render.begin(), render.end());
        args.push_back("-o");
        args.push_back((dir / "out.png").string());
        const Run r = run_process(args, env, (dir / "log.txt").string());
        const double helper = mode == "wait" ? wait_for_builds(cache) : 0;
        std::printf("%d,%s,%d,%.3f,%.3f,%.3f,%s,%d\n", t + 1, mode.c_str(), p + 1, r.wall_s,
                    r.cpu_s, helper, r.kernel.c_str(), r.status);
        std::fflush(stdout);
        failures += r.status != 0;
        wall[mode][p].push_back(r.wall_s);
        cpu[mode][p].push_back(r.cpu_s);
        helper_cpu[mode][p].push_back(helper);
      }
      wait_for_builds(cache);  // no build left beside the next trial
    }
  }
  fs::remove_all(root);
  std::cout << "\nmode,process,median_wall_s,median_cpu_s,median_helper_cpu_s  (over " << trials
            << " trials)\n";
  for (const std::string& m : modes)
    for (int p = 0; p < processes; ++p)
      std::printf("%s,%d,%.3f,%.3f,%.3f\n", m.c_str(), p + 1,
                  twinray_bench::quantile(wall[m][p], 0.5), twinray_bench::quantile(cpu[m][p], 0.5),
                  twinray_bench::quantile(helper_cpu[m][p], 0.5));
  if (failures) std::cerr << "startup_bench: " << failures << " process(es) failed\n";
  return failures ? 1 : 0;
}
