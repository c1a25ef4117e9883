// embree_bench's device configuration reaches Embree: from --device-config, and from
// TWINRAY_EMBREE_DEVICE_CONFIG, the way `twinray bench --against` hands it on. Embree
// refuses "threads=x" (not a number), so a configuration that arrives makes the program
// stop with status 2 and name it; and with "verbose=2" Embree prints the instruction
// sets it will use, which "isa=avx2" keeps to AVX2 and below.
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "support/subprocess.hpp"

namespace {

using test_support::contains;
using test_support::Result;

// A tiny frame of the demo scene, one mode, one timed run.
Result run_embree_bench(std::vector<std::string> extra, const std::vector<std::string>& env) {
  std::vector<std::string> argv = {TWINRAY_EMBREE_BENCH_EXE,
                                   "--scenes",
                                   "demo",
                                   "--modes",
                                   "single",
                                   "--runs",
                                   "1",
                                   "--width",
                                   "32",
                                   "--height",
                                   "18"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  test_support::RunOptions options;
  // None inherited from the shell that runs the tests; then the test's own.
  options.env = {"TWINRAY_EMBREE_DEVICE_CONFIG"};
  options.env.insert(options.env.end(), env.begin(), env.end());
  options.timeout_s = 120;
  return test_support::run(argv, options);
}

// Embree's verbose "Config" block: the ISA line of what the device will use.
std::string config_isa_line(const std::string& report) {
  size_t config = report.find("  Config");
  if (config == std::string::npos) return "";
  size_t isa = report.find("ISA", config);
  if (isa == std::string::npos) return "";
  return report.substr(isa, report.find('\n', isa) - isa);
}

}  // namespace

TEST_CASE("embree_bench: without a configuration, Embree's defaults render the frame") {
  Result r = run_embree_bench({}, {});
  REQUIRE_MESSAGE(r.status == 0, r.err);
  CHECK(contains(r.out, "demo,embree-user-single,float,32,18,"));
  CHECK(!contains(r.err, "device configuration"));
}

TEST_CASE("embree_bench: --device-config goes to rtcNewDevice") {
  Result refused = run_embree_bench({"--device-config", "threads=x"}, {});
  CHECK(refused.status == 2);
  CHECK(contains(refused.err, "Embree refused the device configuration 'threads=x'"));
  CHECK(!contains(refused.out, "demo,embree"));

  Result avx2 = run_embree_bench({"--device-config", "isa=avx2,verbose=2"}, {});
  REQUIRE_MESSAGE(avx2.status == 0, avx2.err);
  CHECK(contains(avx2.err, "Embree device configuration: isa=avx2,verbose=2"));
  const std::string isa = config_isa_line(avx2.out);  // Embree's report goes to stdout
  REQUIRE_MESSAGE(!isa.empty(), avx2.out);
  CHECK(contains(isa, "SSE2"));
  CHECK(!contains(isa, "AVX512"));
  CHECK(contains(avx2.out, "demo,embree-user-single,float,32,18,"));
}

TEST_CASE("embree_bench: TWINRAY_EMBREE_DEVICE_CONFIG, which --device-config overrides") {
  Result refused = run_embree_bench({}, {"TWINRAY_EMBREE_DEVICE_CONFIG=threads=x"});
  CHECK(refused.status == 2);
  CHECK(contains(refused.err, "Embree refused the device configuration 'threads=x'"));

  Result overridden = run_embree_bench({"--device-config", "verbose=0"},
                                       {"TWINRAY_EMBREE_DEVICE_CONFIG=threads=x"});
  CHECK_MESSAGE(overridden.status == 0, overridden.err);
  CHECK(contains(overridden.err, "Embree device configuration: verbose=0"));
}
