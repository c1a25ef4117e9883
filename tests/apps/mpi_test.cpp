// `twinray render` and `twinray movie` across the ranks of an MPI job on this machine
// (mpirun --oversubscribe), against the same command in one process: the images, the
// frames and the MP4 are the same bytes; a killed rank fails the job and the rerun
// finishes the same movie; ranks that disagree are refused before any rendering.
// POSIX only; built when twinray is built with MPI and mpirun is found.
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <dirent.h>
#include <unistd.h>

#include <doctest/doctest.h>

#include "support/subprocess.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kExe = TWINRAY_EXE;
const std::string kMpirun = TWINRAY_MPIRUN;
const std::string kScenes = TWINRAY_SCENES_DIR;
const std::string kWork = TWINRAY_TEST_WORK_DIR;

using test_support::contains;
using test_support::read_file;
using test_support::Result;

// Open MPI refuses root unless told; CI runs as root.
const std::vector<std::string> kMpiEnv = {"OMPI_ALLOW_RUN_AS_ROOT=1",
                                          "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1"};

test_support::RunOptions in(const std::string& dir) {
  test_support::RunOptions o;
  o.cwd = dir;
  o.env = kMpiEnv;
  o.timeout_s = 240;
  return o;
}

// twinray ARGS in one process.
Result alone(std::vector<std::string> args, const std::string& dir) {
  args.insert(args.begin(), kExe);
  return test_support::run(args, in(dir));
}

// mpirun -np RANKS twinray ARGS.
std::vector<std::string> mpirun(int ranks, std::vector<std::string> args) {
  std::vector<std::string> argv = {kMpirun, "--oversubscribe", "-np", std::to_string(ranks), kExe};
  argv.insert(argv.end(), args.begin(), args.end());
  return argv;
}

Result ranks(int n, const std::vector<std::string>& args, const std::string& dir) {
  return test_support::run(mpirun(n, args), in(dir));
}

int count_frames(const std::string& folder) {
  if (!fs::is_directory(folder)) return 0;
  int n = 0;
  for (const std::string& name : test_support::listing(folder))
    if (name.rfind("frame_", 0) == 0 && name.size() == 16 && name.substr(12) == ".png") ++n;
  return n;
}

// The process among `parent`'s children that MPI made rank `rank`.
pid_t child_of_rank(pid_t parent, int rank) {
  const std::string wanted = "OMPI_COMM_WORLD_RANK=" + std::to_string(rank);
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string stat = read_file(e.path().string() + "/stat");
    // pid (comm) state ppid ...: comm may hold spaces, so read after the last ')'.
    size_t close = stat.rfind(')');
    if (close == std::string::npos) continue;
    char state = 0;
    int ppid = 0;
    if (std::sscanf(stat.c_str() + close + 1, " %c %d", &state, &ppid) != 2 || ppid != parent)
      continue;
    std::string env = read_file(e.path().string() + "/environ");
    for (size_t at = 0; at < env.size(); at = env.find('\0', at) + 1) {
      if (env.compare(at, wanted.size() + 1, wanted + '\0') == 0) return std::stoi(name);
      if (env.find('\0', at) == std::string::npos) break;
    }
  }
  return -1;
}

bool is_zombie(pid_t pid) {
  std::string stat = read_file("/proc/" + std::to_string(pid) + "/stat");
  size_t close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] == 'Z';
}

const std::vector<std::string> kMovie = {"movie",        kScenes + "/movie2.json",
                                         "-o",           "m.mp4",
                                         "--width",      "320",
                                         "--height",     "240",
                                         "--spp",        "4",
                                         "--frames",     "40",
                                         "--backend",    "cpu",
                                         "--threads",    "1",
                                         "--keep-frames"};

}  // namespace

TEST_CASE("mpi render: 2 and 3 ranks give the one-process image bit for bit (tiles, adaptive)") {
  // 600x520 is 3x3 tiles of 256 with partial ones at the edges.
  for (std::string precision : {"float", "double"}) {
    for (std::string extra : {"", "adaptive", "aov"}) {
      std::vector<std::string> args = {"render",      kScenes + "/demo.json",
                                       "-o",          "out.pfm",
                                       "--width",     "600",
                                       "--height",    "520",
                                       "--precision", precision,
                                       "--backend",   "cpu",
                                       "--threads",   "1",
                                       "--quiet"};
      if (extra == "adaptive")
        args.insert(args.end(), {"--spp", "2", "--adaptive", "8", "--sampler", "r2"});
      if (extra == "aov") args.insert(args.end(), {"--aov", "normal"});
      CAPTURE(precision);
      CAPTURE(extra);
      std::string one = test_support::fresh_folder(kWork, "mpi_render_1");
      Result r1 = alone(args, one);
      REQUIRE(r1.status == 0);
      for (int n : {2, 3}) {
        CAPTURE(n);
        std::string dir = test_support::fresh_folder(kWork, "mpi_render_n");
        Result rn = ranks(n, args, dir);
        CAPTURE(rn.err);
        REQUIRE(rn.status == 0);
        CHECK(read_file(dir + "/out.pfm") == read_file(one + "/out.pfm"));
        CHECK(contains(rn.out, ", " + std::to_string(n) + " ranks (tiles per rank: "));
      }
    }
  }
}

TEST_CASE("mpi render: the OpenCL backend on every rank gives the same image as one process") {
  std::vector<std::string> args = {
      "render", kScenes + "/three_lights.json", "-o", "out.pfm", "--backend", "opencl", "--quiet"};
  std::string one = test_support::fresh_folder(kWork, "mpi_render_cl_1");
  Result r1 = alone(args, one);
  if (r1.status == 3) return;  // no OpenCL device here: the CPU cases cover the tiles
  REQUIRE(r1.status == 0);
  std::string dir = test_support::fresh_folder(kWork, "mpi_render_cl_2");
  Result r2 = ranks(2, args, dir);
  CAPTURE(r2.err);
  REQUIRE(r2.status == 0);
  CHECK(read_file(dir + "/out.pfm") == read_file(one + "/out.pfm"));
}

TEST_CASE("mpi movie: 3 ranks make the one-process MP4 and frames byte for byte") {
  std::string one = test_support::fresh_folder(kWork, "mpi_movie_1");
  Result r1 = alone(kMovie, one);
  REQUIRE(r1.status == 0);
  std::string dir = test_support::fresh_folder(kWork, "mpi_movie_3");
  Result r3 = ranks(3, kMovie, dir);
  CAPTURE(r3.err);
  REQUIRE(r3.status == 0);
  CHECK(contains(r3.out, "40 rendered at"));
  CHECK(contains(r3.out, ", 3 ranks (frames per rank: "));
  const std::string movie = read_file(dir + "/m.mp4");
  CHECK(movie.size() > 1000);
  CHECK(movie == read_file(one + "/m.mp4"));
  const std::vector<std::string> names = test_support::listing(one + "/m.frames");
  CHECK(test_support::listing(dir + "/m.frames") == names);
  for (const std::string& name : names)
    CHECK_MESSAGE(read_file(dir + "/m.frames/" + name) == read_file(one + "/m.frames/" + name),
                  name);
}

TEST_CASE("mpi movie: a killed rank fails the job with no MP4, the rerun resumes to the same MP4") {
  std::string one = test_support::fresh_folder(kWork, "mpi_kill_reference");
  REQUIRE(alone(kMovie, one).status == 0);

  std::string dir = test_support::fresh_folder(kWork, "mpi_kill");
  test_support::Process job = test_support::Process::start(mpirun(3, kMovie), in(dir));
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (count_frames(dir + "/m.frames") < 3 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const pid_t coordinator = child_of_rank(job.pid(), 0), worker = child_of_rank(job.pid(), 1);
  REQUIRE(coordinator > 0);
  REQUIRE(worker > 0);
  ::kill(worker, SIGKILL);
  Result killed = job.finish();
  // mpirun may return before its ranks are gone; a rerun must not meet the old rank 0
  // still running (it would rightly leave that process's temporary files alone).
  deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (::kill(coordinator, 0) == 0 && !is_zombie(coordinator) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  CAPTURE(killed.err);
  CHECK(killed.status != 0);
  CHECK_FALSE(fs::exists(dir + "/m.mp4"));
  const int kept = count_frames(dir + "/m.frames");
  CAPTURE(kept);
  REQUIRE(kept >= 3);
  REQUIRE(kept < 40);  // (if the movie was already done, this test proves nothing)
  // Every frame on disk is complete: the same bytes the reference run wrote.
  for (const std::string& name : test_support::listing(dir + "/m.frames"))
    if (name.rfind("frame_", 0) == 0 && name.find(".tmp-") == std::string::npos)
      CHECK_MESSAGE(read_file(dir + "/m.frames/" + name) == read_file(one + "/m.frames/" + name),
                    name);

  Result again = ranks(3, kMovie, dir);
  CAPTURE(again.err);
  REQUIRE(again.status == 0);
  CHECK(contains(again.out, std::to_string(40 - kept) + " rendered at"));
  CHECK(contains(again.out, std::to_string(kept) + " kept from m.frames/"));
  CHECK(read_file(dir + "/m.mp4") == read_file(one + "/m.mp4"));
  // What the killed job left behind is gone (the killed rank 0's encoding included).
  for (const std::string& name : test_support::listing(dir + "/m.frames"))
    CHECK_MESSAGE(name.find(".tmp-") == std::string::npos, name);
}

TEST_CASE("mpi: ranks that disagree are refused before any rendering, by rank 0 alone") {
  std::string dir = test_support::fresh_folder(kWork, "mpi_mismatch");
  // Ranks 0 and 1 render at 320x240, rank 2 at 320x200 (MPMD: one command per group).
  std::vector<std::string> argv = mpirun(2, kMovie);
  std::vector<std::string> other = kMovie;
  other[7] = "200";
  argv.insert(argv.end(), {":", "-np", "1", kExe});
  argv.insert(argv.end(), other.begin(), other.end());
  Result r = test_support::run(argv, in(dir));
  CAPTURE(r.err);
  CHECK(r.status == 2);
  CHECK(contains(r.err, "twinray: rank 2 derived the key "));
  CHECK(contains(r.err, "differ between the ranks; give every rank the same scene file"));
  CHECK_FALSE(contains(r.err, "[rank"));  // said once, by rank 0
  CHECK_FALSE(fs::exists(dir + "/m.mp4"));
  CHECK_FALSE(fs::exists(dir + "/m.frames"));

  // A scene that every rank finds bad: one message, the exit status of a bad scene.
  test_support::write_file(dir + "/bad.json", "{\"camera\": 3}");
  Result bad = ranks(3, {"render", "bad.json", "-o", "x.png"}, dir);
  CHECK(bad.status == 2);
  CHECK(contains(bad.err, "bad.json"));
  CHECK_FALSE(contains(bad.err, "[rank"));
  CHECK_FALSE(fs::exists(dir + "/x.png"));

  // A missing output folder, seen by rank 0 before the scene is read.
  Result no_folder = ranks(2, {"render", kScenes + "/demo.json", "-o", "nowhere/x.png"}, dir);
  CHECK(no_folder.status == 2);
  CHECK(contains(no_folder.err, "nowhere"));

  // The subcommands that run in one process say so.
  Result info = ranks(2, {"info"}, dir);
  CHECK(info.status == 2);
  CHECK(contains(info.err, "info runs in one process; render and movie run across the ranks"));
}
