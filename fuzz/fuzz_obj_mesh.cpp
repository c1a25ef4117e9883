// libFuzzer target: OBJ meshes (io/obj_mesh.hpp). Any input must either load as a mesh
// whose every index is in range and whose normals and uvs validate() accepts, or be
// refused with twinray::Error(InvalidInput); and read in pieces of a few bytes it must
// give the same mesh, or the same error, as read in one piece.
#include <cstddef>
#include <cstdint>
#include <string>

#include <twinray/core/error.hpp>
#include <twinray/io/obj_mesh.hpp>
#include <twinray/scene/validate.hpp>

#include "fuzz_limits.hpp"

namespace {

// The mesh, or the error's message.
template <class T>
std::string outcome(const std::string& text, long long chunk_bytes, twinray::Mesh<T>& mesh) {
  twinray::io::ObjLimits limits = fuzz::obj_limits();
  limits.chunk_bytes = chunk_bytes;
  try {
    mesh = twinray::io::parse_obj_mesh<T>(text, "fuzz.obj", limits);
    return "";
  } catch (const twinray::Error& e) {
    if (e.kind() != twinray::ErrorKind::InvalidInput) __builtin_trap();
    return e.what();
  }
}

template <class T>
void same_in_pieces(const std::string& text) {
  twinray::Mesh<T> whole, cut;
  const std::string a = outcome(text, 1ll << 20, whole);
  const std::string b = outcome(text, 1 + static_cast<long long>(text.size() % 7), cut);
  if (a != b || whole.vertices != cut.vertices || whole.triangles != cut.triangles ||
      whole.normals != cut.normals || whole.normal_triangles != cut.normal_triangles ||
      whole.uvs != cut.uvs || whole.uv_triangles != cut.uv_triangles)
    __builtin_trap();
}

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
  same_in_pieces<float>(text);
  return 0;
}
