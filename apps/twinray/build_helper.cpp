// The `twinray` command as its own OpenCL build helper (build_helper.hpp).
#include "build_helper.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl/device.hpp>
#include <twinray/backend/opencl/program.hpp>
#endif

namespace twinray_cli {

namespace {
const char kFlag[] = "--opencl-build-helper";
}  // namespace

bool is_build_helper(int argc, char** argv) {
  return argc > 1 && std::strcmp(argv[1], kFlag) == 0;
}

int run_build_helper(int argc, char** argv) {
#ifdef TWINRAY_WITH_OPENCL
  if (argc != 8 || std::strcmp(argv[2], "--device") != 0 ||
      std::strcmp(argv[4], "--options") != 0 || std::strcmp(argv[6], "--kernel") != 0) {
    std::cerr << "twinray: " << kFlag
              << " is internal: --device N --options O --kernel K builds an OpenCL program "
                 "into the disk caches\n";
    return 2;
  }
  // Starts once the process that started it has ended (it is then adopted by another),
  // or after 5 s where that process goes on: the first process writes its image
  // without the helper loading and compiling beside it.
  const pid_t parent = getppid();
  for (int i = 0; i < 500 && getppid() == parent; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  // The build is for later processes and should take nothing from the foreground ones:
  // SCHED_IDLE (Linux) runs it only on a core nothing else wants, so a process started
  // while it builds renders as fast as on an idle machine (at nice 10 it still took a
  // share of a core from them); nice 10 where SCHED_IDLE is not there. Set before
  // the OpenCL platform starts its threads, which inherit it.
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, 0);
  if (errno == 0) setpriority(PRIO_PROCESS, 0, std::min(nice + 10, 19));
#ifdef SCHED_IDLE
  sched_param idle{};
  sched_setscheduler(0, SCHED_IDLE, &idle);
#endif
  try {
    const std::vector<twinray::opencl::DeviceInfo> devices = twinray::opencl::list_devices();
    const int index = std::max(0, std::atoi(argv[3]));
    if (index >= static_cast<int>(devices.size())) return 1;
    // The program cache's own context is not needed: the build makes its own.
    twinray::opencl::ProgramCache programs(nullptr, devices[index]);
    return programs.build_for_later_processes(argv[5], argv[7]) ? 0 : 1;
  } catch (const std::exception&) {
    return 1;
  }
#else
  (void)argc, (void)argv;
  std::cerr << "twinray: " << kFlag << ": this twinray was built without OpenCL\n";
  return 2;
#endif
}

void register_build_helper() {
#ifdef TWINRAY_WITH_OPENCL
  std::vector<char> path(4096);
  const ssize_t n = ::readlink("/proc/self/exe", path.data(), path.size() - 1);
  if (n <= 0) return;
  twinray::opencl::set_build_helper({std::string(path.data(), static_cast<size_t>(n)), kFlag});
#endif
}

}  // namespace twinray_cli
