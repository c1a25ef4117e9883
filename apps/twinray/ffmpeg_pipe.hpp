// MP4 output through the ffmpeg program (Debian ffmpeg): frames are written to its
// standard input as raw 8-bit RGB and encoded as H.264 in yuv420p, the form every
// player reads. yuv420p needs even dimensions: a frame of odd width or height is
// padded by repeating its last column or row (no black edge), so a 401x301 movie is
// stored as 402x302.
//
//   std::string ffmpeg = twinray::io::find_ffmpeg();   // before any rendering
//   twinray::io::FfmpegEncoder enc(ffmpeg, "out.mp4.part", width, height, 30.0);
//   for (...) enc.write_frame(rgb8.data(), width, height);
//   enc.finish();                                       // then rename into place
//
// The encoder writes to the path it is given; callers write to a temporary name and
// rename it once finish() returned (a movie is complete or absent).
// POSIX only (posix_spawn, pipes).
#pragma once

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <twinray/core/error.hpp>

extern char** environ;

namespace twinray {
namespace io {
namespace detail {

// A child process with its standard input, output and error as pipes (each optional).
struct ChildProcess {
  pid_t pid = -1;
  int in = -1, out = -1, err = -1;
};

inline void close_fd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

inline ChildProcess spawn(const std::vector<std::string>& argv, bool pipe_in, bool pipe_out,
                          bool pipe_err, bool own_process_group) {
  int in[2] = {-1, -1}, out[2] = {-1, -1}, err[2] = {-1, -1};
  auto make = [](int* p, bool want) {
    if (want && ::pipe2(p, O_CLOEXEC) != 0)
      throw Error(ErrorKind::RuntimeFailure, std::string("pipe: ") + std::strerror(errno));
  };
  make(in, pipe_in);
  make(out, pipe_out);
  make(err, pipe_err);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (pipe_in) posix_spawn_file_actions_adddup2(&actions, in[0], 0);
  if (pipe_out)
    posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  else
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  if (pipe_err) posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  short flags = POSIX_SPAWN_SETSIGDEF;
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGPIPE);
  sigaddset(&defaults, SIGINT);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  if (own_process_group) {
    // Ctrl-C in the terminal reaches twinray, which stops the child itself.
    flags |= POSIX_SPAWN_SETPGROUP;
    posix_spawnattr_setpgroup(&attr, 0);
  }
  posix_spawnattr_setflags(&attr, flags);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  ChildProcess c;
  int rc = posix_spawnp(&c.pid, args[0], &actions, &attr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  for (int* p : {in, out, err}) {
    // Keep our ends: the write end of stdin, the read ends of stdout and stderr.
    if (p == in)
      close_fd(p[0]);
    else
      close_fd(p[1]);
  }
  c.in = in[1];
  c.out = out[0];
  c.err = err[0];
  if (rc != 0) {
    close_fd(c.in), close_fd(c.out), close_fd(c.err);
    throw Error(ErrorKind::RuntimeFailure, "cannot start " + argv[0] + ": " + std::strerror(rc));
  }
  return c;
}

inline std::string read_all(int fd) {
  std::string s;
  char buf[4096];
  for (;;) {
    ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    s.append(buf, static_cast<size_t>(n));
  }
  return s;
}

// The exit status of a child, waited for; -signal if a signal ended it.
inline int wait_child(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1000;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return -1000;
}

inline bool is_executable_file(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

}  // namespace detail

// The ffmpeg program to use: $TWINRAY_FFMPEG if set, else `ffmpeg` on PATH; checked to
// run and to have the H.264 encoder (libx264). Throws Error(BackendUnavailable) with
// what to install otherwise, so a movie fails before any frame is rendered.
inline std::string find_ffmpeg() {
  const char* env = std::getenv("TWINRAY_FFMPEG");
  std::string program;
  if (env && *env) {
    program = env;
    if (!detail::is_executable_file(program))
      throw Error(ErrorKind::BackendUnavailable,
                  "TWINRAY_FFMPEG=" + program + " is not an executable file");
  } else {
    const char* path = std::getenv("PATH");
    std::string dirs = path ? path : "/usr/bin:/bin";
    size_t start = 0;
    while (program.empty() && start <= dirs.size()) {
      size_t colon = dirs.find(':', start);
      std::string dir =
          dirs.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
      std::string candidate = (dir.empty() ? "." : dir) + "/ffmpeg";
      if (detail::is_executable_file(candidate)) program = candidate;
      if (colon == std::string::npos) break;
      start = colon + 1;
    }
    if (program.empty())
      throw Error(ErrorKind::BackendUnavailable,
                  "MP4 output needs the ffmpeg program, and there is no ffmpeg on PATH "
                  "(Debian: apt-get install ffmpeg; or set TWINRAY_FFMPEG to its path)");
  }
  detail::ChildProcess c =
      detail::spawn({program, "-hide_banner", "-encoders"}, false, true, false, false);
  std::string encoders = detail::read_all(c.out);
  detail::close_fd(c.out);
  int status = detail::wait_child(c.pid);
  if (status != 0)
    throw Error(ErrorKind::BackendUnavailable, program + " does not run (`" + program +
                                                   " -encoders` exited with status " +
                                                   std::to_string(status) + ")");
  if (encoders.find("libx264") == std::string::npos)
    throw Error(ErrorKind::BackendUnavailable,
                program +
                    " has no H.264 encoder (libx264); install a build of ffmpeg with "
                    "it (Debian's ffmpeg has it)");
  return program;
}

// Even dimensions for yuv420p: w and h rounded up.
inline int even_up(int v) {
  return v + (v & 1);
}

// One ffmpeg process encoding raw RGB frames from a pipe into an H.264 MP4.
class FfmpegEncoder {
 public:
  // libx264's threads: enough to keep up with the renderer at 4K on a few cores.
  static constexpr int kEncoderThreads = 4;

  FfmpegEncoder(const std::string& program, const std::string& output, int width, int height,
                double fps, int crf = 18)
      : output_(output), width_(width), height_(height) {
    if (width < 1 || height < 1 || !(fps > 0))
      throw invalid_input("movie: bad frame size or frame rate");
    // A write to a pipe whose reader died must come back as EPIPE, not end twinray.
    old_sigpipe_ = std::signal(SIGPIPE, SIG_IGN);
    char rate[64];
    std::snprintf(rate, sizeof rate, "%.10g", fps);
    std::vector<std::string> argv = {
        program, "-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-f", "rawvideo",
        "-pixel_format", "rgb24", "-video_size",
        std::to_string(even_up(width)) + "x" + std::to_string(even_up(height)), "-framerate", rate,
        "-i", "pipe:0", "-an", "-c:v", "libx264",
        // x264's output depends on its thread count, which it takes from the core count
        // by default; a fixed count makes the MP4 the same bytes on any host.
        "-threads", std::to_string(kEncoderThreads), "-preset", "medium", "-crf",
        std::to_string(crf), "-pix_fmt", "yuv420p", "-movflags", "+faststart", "-f", "mp4", output};
    child_ = detail::spawn(argv, true, false, true, true);
    int fd = child_.err;
    errors_ = std::thread([this, fd] {
      std::string text = detail::read_all(fd);
      std::lock_guard<std::mutex> lock(mutex_);
      stderr_text_ = text;
    });
    row_.resize(static_cast<size_t>(even_up(width)) * 3);
  }

  FfmpegEncoder(const FfmpegEncoder&) = delete;
  FfmpegEncoder& operator=(const FfmpegEncoder&) = delete;

  ~FfmpegEncoder() {
    if (child_.pid > 0) abort();
    std::signal(SIGPIPE, old_sigpipe_);
  }

  // One frame of width x height RGB bytes, row 0 at the top.
  void write_frame(const unsigned char* rgb, int width, int height) {
    if (width != width_ || height != height_)
      throw Error(ErrorKind::RuntimeFailure,
                  "movie: a frame of " + std::to_string(width) + "x" + std::to_string(height) +
                      " in a movie of " + std::to_string(width_) + "x" + std::to_string(height_));
    const size_t row_bytes = static_cast<size_t>(width) * 3;
    for (int y = 0; y < even_up(height); ++y) {
      const unsigned char* src = rgb + static_cast<size_t>(std::min(y, height - 1)) * row_bytes;
      std::memcpy(row_.data(), src, row_bytes);
      if (width & 1) std::memcpy(row_.data() + row_bytes, src + row_bytes - 3, 3);
      write_all(row_.data(), row_.size());
    }
    ++frames_;
  }

  // Ends the input, waits for ffmpeg and checks that it succeeded.
  void finish() {
    detail::close_fd(child_.in);
    int status = detail::wait_child(child_.pid);
    child_.pid = -1;
    join_errors();
    if (status != 0) {
      ::unlink(output_.c_str());
      throw Error(ErrorKind::RuntimeFailure,
                  "ffmpeg failed (exit status " + std::to_string(status) + ")" + error_tail());
    }
  }

  // Stops ffmpeg and removes what it wrote.
  void abort() {
    detail::close_fd(child_.in);
    if (child_.pid > 0) {
      ::kill(child_.pid, SIGTERM);
      detail::wait_child(child_.pid);
      child_.pid = -1;
    }
    join_errors();
    ::unlink(output_.c_str());
  }

  long long frames() const { return frames_; }

 private:
  void write_all(const unsigned char* p, size_t n) {
    while (n > 0) {
      ssize_t w = ::write(child_.in, p, n);
      if (w < 0 && errno == EINTR) continue;
      if (w < 0) {
        int e = errno;
        abort();
        throw Error(
            ErrorKind::RuntimeFailure,
            "ffmpeg stopped reading frames (" + std::string(std::strerror(e)) + ")" + error_tail());
      }
      p += w;
      n -= static_cast<size_t>(w);
    }
  }

  void join_errors() {
    if (errors_.joinable()) errors_.join();
    detail::close_fd(child_.err);
  }

  std::string error_tail() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string t = stderr_text_;
    while (!t.empty() && (t.back() == '\n' || t.back() == '\r')) t.pop_back();
    if (t.size() > 600) t = "..." + t.substr(t.size() - 600);
    return t.empty() ? "" : ": " + t;
  }

  std::string output_;
  int width_, height_;
  detail::ChildProcess child_;
  std::thread errors_;
  std::mutex mutex_;
  std::string stderr_text_;
  std::vector<unsigned char> row_;
  long long frames_ = 0;
  void (*old_sigpipe_)(int) = SIG_DFL;
};

}  // namespace io
}  // namespace twinray
