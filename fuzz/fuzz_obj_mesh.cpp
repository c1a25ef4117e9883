// libFuzzer target: OBJ meshes (io/obj_mesh.hpp). Any input must either load as a mesh
// whose every index is in range and whose normals and uvs validate() accepts, or be
// refused with twinray::Error(InvalidInput).
#include <cstddef>
#include <cstdint>
#include <string>

#include <twinray/core/error.hpp>
#include <twinray/io/obj_mesh.hpp>
#include <twinray/scene/validate.hpp>

#include "fuzz_limits.hpp"

namespace {

template <class T>
void load(const std::string& text) {
  const twinray::io::ObjLimits limits = fuzz::obj_limits();
  try {
    twinray::Mesh<T> mesh = twinray::io::parse_obj_mesh<T>(text, "fuzz.obj", limits);
    for (const auto& tri : mesh.triangles)
      for (int index : tri)
        if (index < 0 || static_cast<size_t>(index) >= mesh.vertices.size()) __builtin_trap();
    try {
      twinray::detail::validate_mesh_attributes("fuzz", mesh, 1);
    } catch (const twinray::Error&) {
      __builtin_trap();  // the loader made a mesh the renderer would refuse
    }
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
