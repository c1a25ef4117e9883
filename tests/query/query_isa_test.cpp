// The CPU backend's query answers are the same bits whatever instruction set its code
// is compiled for: SSE2, AVX2 with FMA, and AVX-512 (query_isa_program.cpp, built once
// per set). Sets this machine cannot run are skipped, and the test says which.
#include <doctest/doctest.h>

#include <string>
#include <utility>
#include <vector>

#include "support/subprocess.hpp"

TEST_CASE("query answers are the same bits for SSE2, AVX2 and AVX-512 builds") {
  __builtin_cpu_init();
  const std::vector<std::pair<std::string, bool>> programs = {
      {TWINRAY_QUERY_ISA_SSE2, true},
      {TWINRAY_QUERY_ISA_AVX2, __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")},
      {TWINRAY_QUERY_ISA_AVX512,
       __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq")}};
  std::string reference;
  int compared = 0;
  for (const auto& program : programs) {
    if (!program.second) {
      MESSAGE("skipped: this CPU cannot run " << program.first);
      continue;
    }
    test_support::Result r = test_support::run({program.first});
    CAPTURE(program.first);
    CAPTURE(r.err);
    REQUIRE(r.status == 0);
    CHECK(r.out.find(" hits)") != std::string::npos);
    // Packets on the 8-wide trees, answering as the single-ray walk does.
    CHECK(r.out.find("with packets") != std::string::npos);
    CHECK(r.out.find("OTHER ANSWERS") == std::string::npos);
    if (reference.empty())
      reference = r.out;
    else
      CHECK(r.out == reference);
    ++compared;
  }
  MESSAGE("compared " << compared << " instruction sets:\n" << reference);
  CHECK(compared >= 1);
}
