// The window of `twinray view` (SDL2; compiled only when SDL2 was found, see
// view.cmake). The keys and what to render next are view_controls.hpp's; this file
// only opens the window, turns SDL's key events into view::Key, runs the renderer on a
// thread of its own so the window keeps answering, and shows what it made.
#pragma once

#include <string>

#include <twinray/io/scene_json.hpp>

namespace twinray_cli {
namespace view {

struct WindowOptions {
  std::string scene_name;            // for the title
  std::string screenshot_dir = ".";  // where p saves twinray-view-NNN.png
  double target_ms = 40.0;           // aim of a reduced-resolution render
};

// Opens the window and runs until it is closed (or q / Esc). Returns the exit status.
// Throws twinray::Error(BackendUnavailable) when no window can be opened.
template <class T>
int run_window(const twinray::io::SceneFile<T>& scene, const WindowOptions& options);

}  // namespace view
}  // namespace twinray_cli
