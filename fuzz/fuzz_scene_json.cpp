// libFuzzer target: scene files (io/scene_json.hpp). Any input must either load or be
// refused with twinray::Error(InvalidInput); a crash, a sanitizer report, another
// exception type, a hang or a huge allocation is a bug. Relative `obj` paths resolve
// against fuzz/corpus/obj, so inputs can reach the OBJ loader through a scene.
#include <cstddef>
#include <cstdint>
#include <string>

#include <twinray/core/error.hpp>
#include <twinray/scene/validate.hpp>
#include <twinray/io/scene_json.hpp>

#include "fuzz_limits.hpp"

namespace {

template <class T>
void load(const std::string& text) {
  const twinray::io::SceneLimits limits = fuzz::scene_limits();
  try {
    twinray::io::SceneFile<T> f =
        twinray::io::parse_scene<T>(text, "fuzz.json", TWINRAY_FUZZ_OBJ_DIR, limits);
    // What the loader accepts, the core must accept too.
    twinray::validate(f.camera);
    twinray::validate(f.scene);
    twinray::validate(f.options);
  } catch (const twinray::Error& e) {
    if (e.kind() != twinray::ErrorKind::InvalidInput) __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  load<float>(text);
  load<double>(text);
  return 0;
}
