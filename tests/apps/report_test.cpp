// `twinray report --quick -o DIR` (docs/command-line.md): runs, and writes the CSV, the Markdown
// table and the two plots, with every configuration on both backends bit-identical.
#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "support/subprocess.hpp"

namespace {

using test_support::read_file;

// Runs twinray with `args`; what it printed (stdout, then stderr) goes to `log` when
// one is given. Returns the exit status.
int twinray(std::vector<std::string> args, const std::string& log = "") {
  args.insert(args.begin(), TWINRAY_EXE);
  test_support::Result r = test_support::run(args);
  if (!log.empty()) test_support::write_file(log, r.out + r.err);
  return r.status;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.push_back(cell);
      cell.clear();
    } else {
      cell += c;
    }
  }
  cells.push_back(cell);
  return cells;
}

}  // namespace

TEST_CASE("report: --quick writes the CSV, the Markdown table and the plots") {
  const std::string dir = std::string(TWINRAY_REPORT_WORK_DIR) + "/quick";
  std::filesystem::remove_all(dir);
  const std::string log = std::string(TWINRAY_REPORT_WORK_DIR) + "/quick.log";
  std::filesystem::create_directories(TWINRAY_REPORT_WORK_DIR);
  int status = twinray({"report", "--quick", "--quiet", "-o", dir}, log);
  INFO(read_file(log));
  REQUIRE(status == 0);

  std::istringstream csv(read_file(dir + "/report.csv"));
  std::string header;
  std::getline(csv, header);
  std::vector<std::string> columns = split(header);
  auto column = [&](const std::string& name) {
    for (size_t i = 0; i < columns.size(); ++i)
      if (columns[i] == name) return static_cast<int>(i);
    FAIL("no column " << name);
    return -1;
  };
  const int backend = column("backend"), mode = column("mode"), rmse = column("rmse"),
            differ = column("values_differing_from_cpu"), ms = column("render_ms_median"),
            fvd = column("float_vs_double_rmse");
  column("transfer_ms_median");
  column("build_ms");
  column("psnr_db");
  column("max_abs");
  int rows = 0, adaptive = 0, opencl = 0, with_fvd = 0;
  for (std::string line; std::getline(csv, line);) {
    std::vector<std::string> cells = split(line);
    REQUIRE(cells.size() == columns.size());
    ++rows;
    adaptive += cells[mode] == "adaptive";
    CHECK(std::stod(cells[rmse]) > 0);
    CHECK(std::stod(cells[ms]) > 0);
    with_fvd += !cells[fvd].empty();
    if (cells[backend] == "opencl") {
      ++opencl;
      CHECK(cells[differ] == "0");  // the backends agree, bit for bit
    }
  }
  // 2 scenes x 2 precisions x 3 samplers x (3 uniform + 1 adaptive) x 2 backends.
  CHECK(rows == 96);
  CHECK(adaptive == 24);
  CHECK(opencl == 48);
  CHECK(with_fvd == rows);

  std::string md = read_file(dir + "/report.md");
  CHECK(md.find("## Adaptive sampling against") != std::string::npos);
  CHECK(md.find("## Float against double") != std::string::npos);
  CHECK(md.find("error_vs_time.png") != std::string::npos);
  for (const char* png : {"/error_vs_time.png", "/error_vs_spp.png"}) {
    std::string bytes = read_file(dir + png);
    REQUIRE(bytes.size() > 1000);
    CHECK(bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0);
  }
}

TEST_CASE("report: a missing -o is a usage error") {
  CHECK(twinray({"report", "--quick"}) == 2);
}

TEST_CASE("render: --sampler, --seed and --adaptive, and the scene file's keys") {
  const std::string dir = std::string(TWINRAY_REPORT_WORK_DIR) + "/flags";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string log = dir + "/log";
  auto demo = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"render", "demo", "--quiet", "--width", "24", "--height", "16"});
    return twinray(args, log);
  };
  CHECK(demo({"-o", dir + "/a.pfm", "--sampler", "r2", "--seed", "3", "--spp", "2", "--adaptive",
              "8"}) == 0);
  CHECK(read_file(dir + "/a.pfm").size() > 24 * 16 * 12);
  CHECK(demo({"-o", dir + "/b.pfm", "--sampler", "halton"}) == 2);
  CHECK(demo({"-o", dir + "/b.pfm", "--spp", "4", "--adaptive", "4"}) == 2);
  CHECK(read_file(dir + "/log").find("--adaptive") != std::string::npos);

  auto scene = [&](const std::string& render) {
    std::ofstream f(dir + "/s.json");
    f << R"({"twinray": 1, "image": {"width": 8, "height": 8},
             "camera": {"projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0], "up": [0, 1, 0]},
             "render": )"
      << render << R"(,
             "lights": [{"type": "point", "position": [2, 2, 5], "intensity": 10}],
             "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                          "material": {"color": [1, 1, 1]}}]})";
  };
  scene(
      R"({"spp": 2, "sampler": "stratified", "seed": 7, "adaptive": {"spp": 8, "threshold": 0.1}})");
  CHECK(twinray({"render", dir + "/s.json", "-o", dir + "/c.pfm", "--quiet"}, log) == 0);
  scene(R"({"spp": 4, "adaptive": {"spp": 4}})");
  CHECK(twinray({"render", dir + "/s.json", "-o", dir + "/c.pfm", "--quiet"}, log) == 2);
  CHECK(read_file(dir + "/log").find("render.adaptive.spp") != std::string::npos);
  scene(R"({"sampler": "sobol"})");
  CHECK(twinray({"render", dir + "/s.json", "-o", dir + "/c.pfm", "--quiet"}, log) == 2);
  CHECK(read_file(dir + "/log").find("render.sampler") != std::string::npos);
}
