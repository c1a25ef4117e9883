// The loader limits of the fuzz targets and of tests/fuzz's regression replay: small
// enough that the fuzzer cannot spend its time allocating, and one definition, so a
// crash input replays under exactly the limits it was found with.
#pragma once

#include <twinray/io/obj_mesh.hpp>
#include <twinray/io/scene_json.hpp>

namespace fuzz {

inline twinray::io::SceneLimits scene_limits() {
  twinray::io::SceneLimits limits;
  limits.max_file_bytes = 1 << 20;
  limits.max_obj_file_bytes = 1 << 20;
  limits.max_objects = 1 << 12;
  limits.max_mesh_vertices = 1 << 14;
  limits.max_total_triangles = 1 << 14;
  return limits;
}

inline twinray::io::ObjLimits obj_limits() {
  twinray::io::ObjLimits limits;
  limits.max_file_bytes = 1 << 20;
  limits.max_vertices = 1 << 14;
  limits.max_triangles = 1 << 14;
  limits.max_face_corners = 1 << 10;  // ear clipping a huge face is slow, not wrong
  return limits;
}

}  // namespace fuzz
