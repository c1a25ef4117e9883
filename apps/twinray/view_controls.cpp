// The viewer's window-free logic (view_controls.hpp).
#include "view_controls.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace twinray_cli {
namespace view {

Key key_from_char(char c) {
  switch (c) {
    case 'o':
    case 'O':
      return Key::Projection;
    case '1':
      return Key::Ambient;
    case '2':
      return Key::Diffuse;
    case '3':
      return Key::Specular;
    case 's':
    case 'S':
      return Key::Shadows;
    case 'g':
    case 'G':
      return Key::Glaze;
    case 'b':
    case 'B':
      return Key::Backend;
    case '+':
    case '=':
      return Key::MoreSamples;
    case '-':
    case '_':
      return Key::FewerSamples;
    case ' ':
      return Key::Play;
    case 'p':
    case 'P':
      return Key::Screenshot;
    case 'r':
    case 'R':
      return Key::Reset;
    case 'q':
    case 'Q':
    case 27:  // Esc
      return Key::Quit;
    default:
      return Key::Other;
  }
}

bool ViewController::press(Key key) {
  ViewState& s = state_;
  note_.clear();
  switch (key) {
    case Key::Projection:
      s.projection = s.projection == twinray::Projection::Perspective
                         ? twinray::Projection::Orthographic
                         : twinray::Projection::Perspective;
      break;
    case Key::Ambient:
      s.terms ^= twinray::kAmbient;
      break;
    case Key::Diffuse:
      s.terms ^= twinray::kDiffuse;
      break;
    case Key::Specular:
      s.terms ^= twinray::kSpecular;
      break;
    case Key::Shadows:
      s.shadows = !s.shadows;
      break;
    case Key::Glaze:
      s.glaze = !s.glaze;
      break;
    case Key::Backend: {
      // Auto means whatever rendered last; switch away from that.
      twinray::Backend current = backend_known_ ? shown_backend_ : s.backend;
      s.backend =
          current == twinray::Backend::OpenCL ? twinray::Backend::Cpu : twinray::Backend::OpenCL;
      full_ms_ = 0;  // the other backend has its own speed
      break;
    }
    case Key::Left:
      s.yaw -= kOrbitStep;
      break;
    case Key::Right:
      s.yaw += kOrbitStep;
      break;
    case Key::Up:
    case Key::Down: {
      // Kept where apply_view's clamp leaves it, so that the way back is immediate.
      double next = s.pitch + (key == Key::Up ? kOrbitStep : -kOrbitStep);
      if (std::fabs(next) > 3.0) return false;
      s.pitch = next;
      break;
    }
    case Key::MoreSamples:
      if (s.spp >= kMaxViewSpp) return false;
      s.spp = std::min(kMaxViewSpp, s.spp * 2);
      break;
    case Key::FewerSamples:
      if (s.spp <= 1) return false;
      s.spp = std::max(1, s.spp / 2);
      break;
    case Key::Play:
      if (s.frames <= 0) {
        note_ = "no animation in this scene";
        return false;
      }
      s.playing = !s.playing;
      last_advance_s_ = -1;
      return false;  // the image changes when the next frame is due
    case Key::Screenshot:
      screenshot_pending_ = true;
      return false;
    case Key::Reset: {
      ViewState keep = s;
      s = initial_;
      s.backend = keep.backend;
      s.frame = keep.frame;
      s.playing = keep.playing;
      break;
    }
    case Key::Quit:
      quit_ = true;
      return false;
    case Key::Other:
      return false;
  }
  changed();
  return true;
}

int ViewController::preview_divisor(double full_ms, double target_ms) {
  int d = 1;
  while (d < 8 && full_ms / (static_cast<double>(d) * d) > target_ms) d *= 2;
  return d;
}

bool ViewController::next_job(double now_s, Job& job) {
  ViewState& s = state_;
  // Playback: one animation frame per 1/fps seconds, or slower when rendering is.
  // (A PNG asked for while playing: the frame shown is finished at full size first.)
  bool hold_frame = screenshot_pending_ && !screenshot_due();
  if (s.playing && s.frames > 0 && shown_generation_ == generation_ && !hold_frame) {
    if (last_advance_s_ < 0 || now_s - last_advance_s_ >= 1.0 / s.fps) {
      last_advance_s_ = now_s;
      s.frame = (s.frame + 1) % s.frames;
      changed();
    }
  }
  int divisor;
  if (started_generation_ != generation_) {
    // A new state: quickly first (unknown speed: a quarter size), unless the full
    // render is known to be fast enough. While playing, stay at the preview size.
    divisor = full_ms_ > 0 ? preview_divisor(full_ms_, target_ms_) : 4;
  } else if (started_divisor_ > 1 && shown_generation_ == generation_ && shown_divisor_ > 1 &&
             (!s.playing || screenshot_pending_)) {
    divisor = 1;  // refine the state shown at reduced size
  } else {
    return false;
  }
  if (started_generation_ == generation_ && started_divisor_ == divisor) return false;
  job.state = s;
  job.generation = generation_;
  job.divisor = divisor;
  started_generation_ = generation_;
  started_divisor_ = divisor;
  return true;
}

bool ViewController::finish(const Result& r) {
  if (r.failed) {
    note_ = r.error;
    // A backend that is not there: back to the one that worked.
    if (state_.backend == twinray::Backend::OpenCL) {
      state_.backend = backend_known_ ? shown_backend_ : twinray::Backend::Cpu;
      if (state_.backend == twinray::Backend::OpenCL) state_.backend = twinray::Backend::Cpu;
      changed();
    }
    return false;
  }
  backend_known_ = true;
  shown_backend_ = r.backend;
  if (state_.backend == twinray::Backend::Auto) state_.backend = r.backend;
  last_ms_ = r.ms;
  last_divisor_ = r.divisor;
  if (r.divisor == 1)
    full_ms_ = r.ms;
  else if (full_ms_ <= 0)
    full_ms_ = r.ms * r.divisor * r.divisor;  // an estimate until a full render ran
  shown_generation_ = r.generation;
  shown_divisor_ = r.divisor;
  return r.generation == generation_;
}

std::string ViewController::title(const std::string& scene) const {
  const ViewState& s = state_;
  std::ostringstream t;
  char ms[64];
  std::snprintf(ms, sizeof ms, "%.1f ms, %.1f fps", last_ms_,
                last_ms_ > 0 ? 1000.0 / last_ms_ : 0.0);
  t << "twinray view " << scene << " | "
    << twinray::to_string(backend_known_ ? shown_backend_ : s.backend) << " | " << ms;
  if (last_divisor_ > 1) t << " (1/" << last_divisor_ << " size)";
  t << " | " << (s.projection == twinray::Projection::Perspective ? "perspective" : "orthographic");
  t << ", spp " << s.spp;
  std::string terms;
  if (s.terms & twinray::kAmbient) terms += "A";
  if (s.terms & twinray::kDiffuse) terms += "D";
  if (s.terms & twinray::kSpecular) terms += "S";
  t << ", terms " << (terms.empty() ? "none" : terms);
  t << ", shadows " << (s.shadows ? "on" : "off") << ", glaze " << (s.glaze ? "on" : "off");
  if (s.frames > 0) t << " | frame " << s.frame << "/" << s.frames << (s.playing ? " playing" : "");
  if (!note_.empty()) t << " | " << note_;
  return t.str();
}

}  // namespace view
}  // namespace twinray_cli
