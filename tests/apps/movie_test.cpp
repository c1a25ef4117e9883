// `twinray movie`, the real program: short movies on both backends checked with
// ffprobe, odd sizes, a missing ffmpeg, bad ranges, and a movie that is killed and
// resumed. POSIX only.
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <doctest/doctest.h>

#include "support/subprocess.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kExe = TWINRAY_EXE;
const std::string kScenes = TWINRAY_SCENES_DIR;
const std::string kWork = TWINRAY_TEST_WORK_DIR;

using Run = test_support::Result;
using test_support::contains;
using test_support::read_file;

std::string fresh(const std::string& name) {
  return test_support::fresh_folder(kWork, name);
}

// Runs argv in dir; `env` entries are set first.
Run run(const std::vector<std::string>& argv, const std::string& dir,
        const std::vector<std::pair<std::string, std::string>>& env = {}) {
  test_support::RunOptions o;
  o.cwd = dir;
  for (const auto& e : env) o.env.push_back(e.first + "=" + e.second);
  return test_support::run(argv, o);
}

Run twinray(std::vector<std::string> args, const std::string& dir,
            const std::vector<std::pair<std::string, std::string>>& env = {}) {
  args.insert(args.begin(), kExe);
  return run(args, dir, env);
}

// Starts argv in dir, to be signalled and collected.
test_support::Process start(const std::vector<std::string>& argv, const std::string& dir) {
  test_support::RunOptions o;
  o.cwd = dir;
  return test_support::Process::start(argv, o);
}

// "codec_name=h264\nwidth=..." of the first video stream, frames counted.
std::string probe(const std::string& dir, const std::string& file) {
  Run r = run({"ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
               "stream=codec_name,pix_fmt,width,height,nb_read_frames", "-of",
               "default=noprint_wrappers=1", file},
              dir);
  REQUIRE(r.status == 0);
  return r.out;
}

// One MD5 per decoded frame: equal when two movies show the same pictures.
std::string frame_md5s(const std::string& dir, const std::string& file) {
  Run r = run({"ffmpeg", "-v", "error", "-i", file, "-f", "framemd5", "-"}, dir);
  REQUIRE(r.status == 0);
  std::string lines;
  for (size_t at = 0; at < r.out.size();) {
    size_t nl = r.out.find('\n', at);
    std::string line = r.out.substr(at, nl == std::string::npos ? std::string::npos : nl - at);
    if (!line.empty() && line[0] != '#') lines += line.substr(line.rfind(',') + 1) + "\n";
    if (nl == std::string::npos) break;
    at = nl + 1;
  }
  return lines;
}

bool opencl_available() {
  static int available = -1;
  if (available < 0) {
    std::string dir = fresh("opencl_probe");
    Run r = twinray({"render", kScenes + "/movie1.json", "-o", "x.png", "--width", "8", "--height",
                     "6", "--backend", "opencl", "--quiet"},
                    dir);
    available = r.status == 0;
  }
  return available == 1;
}

int count_frames(const std::string& folder) {
  int n = 0;
  if (!fs::is_directory(folder)) return 0;
  for (const auto& e : fs::directory_iterator(folder)) {
    std::string name = e.path().filename().string();
    if (name.rfind("frame_", 0) == 0 && name.size() == 16 && name.substr(12) == ".png") ++n;
  }
  return n;
}

}  // namespace

TEST_CASE("movie: H.264 yuv420p MP4 with the right frame count on both backends bit for bit") {
  std::vector<std::string> backends = {"cpu"};
  if (opencl_available())
    backends.push_back("opencl");
  else
    MESSAGE("no OpenCL device: the CPU backend only");
  std::string first_frames;
  for (const std::string& backend : backends) {
    CAPTURE(backend);
    std::string dir = fresh("movie_" + backend);
    Run r = twinray({"movie", kScenes + "/movie2.json", "-o", "m.mp4", "--width", "64", "--height",
                     "48", "--frames", "7", "--backend", backend, "--keep-frames"},
                    dir);
    CAPTURE(r.err);
    REQUIRE(r.status == 0);
    CHECK(contains(r.out, "m.mp4: 7 frames, 64x48 at 30 fps, H.264"));
    CHECK(contains(r.out, "backend " + backend));
    std::string p = probe(dir, "m.mp4");
    CHECK(contains(p, "codec_name=h264"));
    CHECK(contains(p, "pix_fmt=yuv420p"));
    CHECK(contains(p, "width=64"));
    CHECK(contains(p, "height=48"));
    CHECK(contains(p, "nb_read_frames=7"));
    // The kept frames: the same PNG bytes from either backend.
    CHECK(count_frames(dir + "/m.frames") == 7);
    std::string frames;
    for (int k = 0; k < 7; ++k) {
      char name[32];
      std::snprintf(name, sizeof name, "/m.frames/frame_%06d.png", k);
      frames += read_file(dir + name);
    }
    if (first_frames.empty())
      first_frames = frames;
    else
      CHECK(frames == first_frames);
    // Frames differ from each other: something moves.
    CHECK(read_file(dir + "/m.frames/frame_000000.png") !=
          read_file(dir + "/m.frames/frame_000006.png"));
    // `render --frame K` renders the same picture as the movie's frame K.
    r = twinray({"render", kScenes + "/movie2.json", "-o", "f5.png", "--width", "64", "--height",
                 "48", "--frame", "5", "--backend", backend},
                dir);
    REQUIRE(r.status == 0);
    CHECK(read_file(dir + "/f5.png") == read_file(dir + "/m.frames/frame_000005.png"));
  }
}

TEST_CASE("movie: odd sizes are stored even - --fps and --from/--to - no frames folder after") {
  std::string dir = fresh("movie_odd");
  Run r = twinray({"movie", kScenes + "/movie1.json", "-o", "odd.mp4", "--width", "45", "--height",
                   "33", "--from", "10", "--to", "14", "--fps", "12", "--backend", "cpu"},
                  dir);
  CAPTURE(r.err);
  REQUIRE(r.status == 0);
  CHECK(contains(r.out, "5 frames (10 to 14), 45x33 (stored as 46x34) at 12 fps"));
  std::string p = probe(dir, "odd.mp4");
  CHECK(contains(p, "width=46"));
  CHECK(contains(p, "height=34"));
  CHECK(contains(p, "nb_read_frames=5"));
  Run rate = run({"ffprobe", "-v", "error", "-select_streams", "v:0", "-show_entries",
                  "stream=r_frame_rate", "-of", "default=noprint_wrappers=1", "odd.mp4"},
                 dir);
  CHECK(contains(rate.out, "r_frame_rate=12/1"));
  CHECK_FALSE(fs::exists(dir + "/odd.frames"));
}

TEST_CASE("movie: a missing ffmpeg and bad input fail before any rendering and leave nothing") {
  std::string dir = fresh("movie_errors");
  std::string empty_path = fresh("movie_errors_path");
  struct Case {
    std::vector<std::string> args;
    std::vector<std::pair<std::string, std::string>> env;
    int status;
    std::string message;
  } cases[] = {
      {{"movie", kScenes + "/movie1.json", "-o", "m.mp4"},
       {{"PATH", empty_path}},
       3,
       "MP4 output needs the ffmpeg program, and there is no ffmpeg on PATH"},
      {{"movie", kScenes + "/movie1.json", "-o", "m.mp4"},
       {{"TWINRAY_FFMPEG", "/nonexistent/ffmpeg"}},
       3,
       "TWINRAY_FFMPEG=/nonexistent/ffmpeg is not an executable file"},
      {{"movie", kScenes + "/movie1.json", "-o", "m.avi"},
       {},
       2,
       "-o m.avi: a movie is written as MP4; the output must end in .mp4"},
      {{"movie", kScenes + "/movie1.json", "-o", "m.mp4", "--to", "120"},
       {},
       2,
       "--to 120: the movie has 120 frames (0 to 119); --frames N makes it longer"},
      {{"movie", kScenes + "/movie1.json", "-o", "m.mp4", "--from", "9", "--to", "3"},
       {},
       2,
       "--from 9 --to 3: the first frame is after the last"},
      {{"movie", kScenes + "/demo.json", "-o", "m.mp4"},
       {},
       2,
       "demo.json has no animation (no \"animation\" key), so there is no movie to make"},
      {{"movie", kScenes + "/movie1.json", "-o", "nofolder/m.mp4"},
       {},
       2,
       "the folder nofolder does not exist"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.message);
    Run r = twinray(c.args, dir, c.env);
    CAPTURE(r.err);
    CHECK(r.status == c.status);
    CHECK(contains(r.err, c.message));
    std::vector<std::string> left;
    for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename());
    CHECK(left.empty());
  }
}

TEST_CASE("movie: killed halfway - the rerun keeps the rendered frames and makes the same movie") {
  std::string dir = fresh("movie_resume");
  std::vector<std::string> args = {kExe,        "movie",     kScenes + "/movie2.json",
                                   "-o",        "r.mp4",     "--width",
                                   "160",       "--height",  "120",
                                   "--spp",     "4",         "--frames",
                                   "24",        "--backend", "cpu",
                                   "--threads", "1"};
  // An uninterrupted movie to compare with.
  std::string ref = fresh("movie_resume_reference");
  Run whole = run(args, ref);
  REQUIRE(whole.status == 0);

  test_support::Process movie = start(args, dir);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (count_frames(dir + "/r.frames") < 3 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(movie.pid(), SIGKILL);
  Run killed = movie.finish();
  CHECK(killed.status == 128 + SIGKILL);
  int kept = count_frames(dir + "/r.frames");
  CAPTURE(kept);
  REQUIRE(kept >= 3);
  REQUIRE(kept < 24);  // (if the movie was already done, this test proves nothing)
  CHECK_FALSE(fs::exists(dir + "/r.mp4"));  // no partial movie

  Run again = run(args, dir);
  CAPTURE(again.err);
  REQUIRE(again.status == 0);
  CHECK(contains(again.out, std::to_string(24 - kept) + " rendered at"));
  CHECK(contains(again.out, std::to_string(kept) + " kept from r.frames/"));
  CHECK(contains(probe(dir, "r.mp4"), "nb_read_frames=24"));
  CHECK(frame_md5s(dir, "r.mp4") == frame_md5s(ref, "r.mp4"));
  CHECK_FALSE(fs::exists(dir + "/r.frames"));
}

TEST_CASE(
    "movie: Ctrl-C stops after the current frame and keeps the frames and says how to go on") {
  std::string dir = fresh("movie_interrupt");
  std::vector<std::string> args = {kExe,        "movie",     kScenes + "/movie1.json",
                                   "-o",        "i.mp4",     "--width",
                                   "160",       "--height",  "120",
                                   "--spp",     "4",         "--frames",
                                   "40",        "--backend", "cpu",
                                   "--threads", "1"};
  test_support::Process movie = start(args, dir);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (count_frames(dir + "/i.frames") < 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(movie.pid(), SIGINT);
  Run r = movie.finish();
  CAPTURE(r.err);
  REQUIRE(r.status == 130);
  CHECK(contains(r.err, "interrupted; "));
  CHECK(contains(r.err, "frames are kept in i.frames/; run the same command again"));
  CHECK_FALSE(fs::exists(dir + "/i.mp4"));
  int kept = count_frames(dir + "/i.frames");
  CHECK(kept >= 2);
  for (const std::string& name : test_support::listing(dir + "/i.frames"))
    CHECK_MESSAGE(name.rfind("encoding.mp4", 0) != 0, name);  // the partial MP4 is gone

  // Other settings: the kept frames are not used.
  args[10] = "1";  // --spp 1
  Run other = run(args, dir);
  CAPTURE(other.err);
  REQUIRE(other.status == 0);
  CHECK(contains(other.err, "frames of another scene or other settings; rendering anew"));
  CHECK(contains(other.out, "40 rendered at"));
  CHECK_FALSE(contains(other.out, "kept"));
}

TEST_CASE("movie: a shared frames folder - another process's temporary files are left alone") {
  std::string dir = fresh("movie_shared_folder");
  fs::create_directories(dir + "/s.frames");
  char host[256] = {};
  REQUIRE(::gethostname(host, sizeof host - 1) == 0);
  // A process of this host that has ended: its pid, once it is reaped.
  test_support::Process gone = start({"true"}, dir);
  const pid_t dead = gone.pid();
  gone.finish();
  const std::string here = std::string(".tmp-") + host + "-";
  const std::string other_host = "frame_000001.png.tmp-another-host-" + std::to_string(::getpid());
  const std::string running = "frame_000002.png" + here + std::to_string(::getpid());
  const std::string left_behind = "frame_000003.png" + here + std::to_string(dead);
  for (const std::string& name : {other_host, running, left_behind})
    test_support::write_file(dir + "/s.frames/" + name, "half a PNG");
  Run r = twinray({"movie", kScenes + "/movie1.json", "-o", "s.mp4", "--width", "64", "--height",
                   "48", "--frames", "4", "--backend", "cpu"},
                  dir);
  CAPTURE(r.err);
  REQUIRE(r.status == 0);
  CHECK(fs::exists(dir + "/s.mp4"));
  // The folder stays for the processes still writing there, with only their files.
  CHECK(test_support::listing(dir + "/s.frames") == std::vector<std::string>{other_host, running});
}

TEST_CASE("movie: kept frames are used again only when nothing that decides their pixels changed") {
  // The scene's light becomes a rect, a sphere light, gains samples; a material turns to
  // glass; an environment appears: each changes the pixels, so each rerun renders anew.
  // The unchanged scene takes its kept frames.
  const std::string base = read_file(kScenes + "/movie1.json");
  const std::string point =
      R"({ "type": "point", "position": [-2, -2, 1], "intensity": 12, "color": [1, 1, 1] })";
  auto with = [&](const std::string& from, const std::string& to) {
    std::string text = base;
    const size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
  };
  const std::string rect =
      R"({ "type": "rect", "corner": [-2, -2, 1], "edge1": [0.5, 0, 0], "edge2": [0, 0, 0.5], "intensity": 12 })";
  const std::string variants[] = {
      with(point, rect),
      with(point, R"({ "type": "sphere", "center": [-2, -2, 1], "radius": 0.3, "intensity": 12 })"),
      with(point, rect.substr(0, rect.size() - 2) + R"(, "samples": 2 })"),
      with(R"("glaze": 0.4 })", R"("glaze": 0.4, "transmission": 0.5 })"),
      with(R"("background": [0, 0, 0] })",
           R"("background": [0, 0, 0], "environment": { "file": ")" + kScenes + R"(/sky.hdr" } })"),
  };
  std::string dir = fresh("movie_settings");
  auto movie = [&](const std::string& text) {
    test_support::write_file(dir + "/scene.json", text);
    Run r = twinray({"movie", "scene.json", "-o", "s.mp4", "--width", "32", "--height", "24",
                     "--frames", "2", "--backend", "cpu", "--keep-frames"},
                    dir);
    CAPTURE(r.err);
    REQUIRE(r.status == 0);
    return r;
  };
  movie(base);
  CHECK(contains(movie(base).out, "2 kept from s.frames/"));
  for (const std::string& text : variants) {
    CAPTURE(text);
    Run r = movie(text);
    CHECK(contains(r.err, "frames of another scene or other settings; rendering anew"));
    CHECK(contains(r.out, "2 rendered at"));
  }
}
