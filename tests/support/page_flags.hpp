// Which pages back an address: the flags Linux lists for the mapping that holds it.
#pragma once

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>

namespace twinray_test {

// The "VmFlags:" line of the mapping of /proc/self/smaps that holds `address`; empty
// where the file cannot be read or no mapping holds it.
inline std::string vm_flags_at(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  const auto a = reinterpret_cast<std::uintptr_t>(address);
  bool inside = false;
  std::string line;
  while (std::getline(smaps, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = lo <= a && a < hi;
      continue;
    }
    if (inside && line.rfind("VmFlags:", 0) == 0) return line;
  }
  return {};
}

inline bool advised_huge(const void* address) {
  // "hg": the mapping was given MADV_HUGEPAGE (proc(5)).
  return vm_flags_at(address).find(" hg") != std::string::npos;
}

// Whether this system can say: a kernel with transparent huge pages, and a readable
// /proc/self/smaps.
inline bool page_flags_known() {
  static const int probe = 0;
  return std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good() &&
         !vm_flags_at(&probe).empty();
}

}  // namespace twinray_test
