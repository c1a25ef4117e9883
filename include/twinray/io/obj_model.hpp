// load_obj_model(): an OBJ file with its materials: the mesh (io/obj_mesh.hpp), the
// materials of its `mtllib` libraries, and their `map_Kd` textures (io/texture_image.hpp).
//
// MTL statements read, and how they map onto twinray's Blinn-Phong material
// (scene/material.hpp), whose ambient and diffuse terms share one colour:
//   Kd       -> color (each channel clamped to [0, 1]), kd = 1
//   Ka       -> ka = mean of its channels
//   Ks       -> ks = mean of its channels
//   Ns       -> shininess (clamped to >= 0)
//   illum    -> 3 or 5 (reflection on) with a non-zero Ks: glaze = min(1, ks)
//   map_Kd   -> texture: the albedo is Kd x the texture at the hit's uv
// Other statements (d, Tr, Ni, bump maps, ...) are ignored.
//
// Missing pieces are warnings, as other tools treat them (Blender's importer loads the
// mesh with a default material): a library that cannot be read, a `usemtl` name no
// library defines, a texture file that cannot be read or decoded. Each names the file
// and line (`spot.obj:2: usemtl red: no material of that name in spot.mtl; the default
// material is used`); `strict` makes them errors. A malformed OBJ is always an error.
#pragma once

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include <twinray/io/obj_mesh.hpp>
#include <twinray/io/texture_image.hpp>
#include <twinray/scene/material.hpp>
#include <twinray/scene/texture.hpp>

#ifdef TWINRAY_WITH_TINYOBJLOADER

namespace twinray {
namespace io {

template <class T>
struct ObjModel {
  // triangle_materials holds indices into `materials`, or -1 for a triangle with no
  // usable `usemtl` (the caller's default material).
  Mesh<T> mesh;
  std::vector<Material<T>> materials;
  std::vector<std::string> material_names;  // `newmtl` names, as `materials`
  std::vector<Texture<T>> textures;         // Material::texture indexes these
  std::vector<std::string> warnings;        // `file:line: problem; what is used instead`
};

struct ObjModelOptions {
  ObjLimits limits;
  TextureLimits texture_limits;
  bool strict = false;  // warnings are errors
};

namespace detail {

inline std::string folder_of(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

inline std::string resolve_beside(const std::string& base_file, const std::string& name) {
  return !name.empty() && name[0] == '/' ? name : folder_of(base_file) + name;
}

// What the loader needs to know of an MTL file's lines: the materials it defines, and
// the line of each one's `map_Kd` (for warnings).
struct MtlLines {
  std::vector<std::string> defined;              // `newmtl` names, in order
  std::map<std::string, long long> map_kd_line;  // material name -> its map_Kd line
};

inline MtlLines scan_mtl(const std::string& mtl) {
  MtlLines out;
  std::string current;
  long long number = 0;
  for (size_t i = 0, n = mtl.size(); i < n;) {
    size_t end = mtl.find('\n', i);
    if (end == std::string::npos) end = n;
    ++number;
    ObjLine t = split_obj_line(std::string_view(mtl.data() + i, end - i));
    i = end + 1;
    if (t.count < 2) continue;
    if (t.token[0] == "newmtl") {
      current = std::string(t.token[1]);
      out.defined.push_back(current);
    }
    if (t.token[0] == "map_Kd") out.map_kd_line[current] = number;
  }
  return out;
}

template <class T>
T channel_mean(const tinyobj::real_t (&c)[3]) {
  return static_cast<T>((double(c[0]) + double(c[1]) + double(c[2])) / 3.0);
}

template <class T>
Material<T> material_from_mtl(const tinyobj::material_t& m, const std::string& where) {
  for (const tinyobj::real_t* values : {m.ambient, m.diffuse, m.specular})
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(values[k]))
        throw invalid_input(where + "material " + m.name + ": a colour value is not finite");
  if (!std::isfinite(m.shininess))
    throw invalid_input(where + "material " + m.name + ": Ns is not finite");
  Material<T> out;
  for (int k = 0; k < 3; ++k)
    out.color[k] = static_cast<T>(std::clamp(double(m.diffuse[k]), 0.0, 1.0));
  out.kd = T(1);
  out.ka = std::max(T(0), channel_mean<T>(m.ambient));
  out.ks = std::max(T(0), channel_mean<T>(m.specular));
  out.shininess = static_cast<T>(std::max(0.0, double(m.shininess)));
  if ((m.illum == 3 || m.illum == 5) && out.ks > T(0)) out.glaze = std::min(T(1), out.ks);
  return out;
}

}  // namespace detail

// Loads an OBJ file and what its materials name. Throws twinray::Error(InvalidInput)
// for a malformed OBJ, and for a warning when options.strict.
template <class T>
ObjModel<T> load_obj_model(const std::string& path, const ObjModelOptions& options = {}) {
  ObjModel<T> model;
  auto warn = [&](const std::string& message) {
    if (options.strict) throw invalid_input(message + " (--strict)");
    model.warnings.push_back(message);
  };
  std::string text = detail::read_small_file(path, options.limits.max_file_bytes, "an OBJ file");

  // The strict line check first; it also names the libraries and `usemtl` lines.
  detail::ObjCounts refs = detail::scan_obj<T>(text, path);
  std::string mtl_text;
  struct Library {
    std::string path;
    detail::MtlLines lines;
  };
  std::vector<Library> libraries;
  for (const detail::ObjReference& lib : refs.libraries) {
    std::string file = detail::resolve_beside(path, lib.name);
    try {
      std::string t = detail::read_small_file(file, options.limits.max_file_bytes, "an MTL file");
      libraries.push_back({file, detail::scan_mtl(t)});
      mtl_text += t;
      mtl_text += "\n";
    } catch (const Error& e) {
      warn(detail::obj_where(path, lib.line) + "mtllib " + lib.name + ": " + e.what() +
           "; its materials are not used");
    }
  }

  std::vector<tinyobj::material_t> materials;
  model.mesh = detail::parse_obj<T>(text, refs, path, options.limits, mtl_text, &materials);

  std::map<std::string, std::string> defined_in;  // material name -> library path
  std::map<std::string, long long> texture_line;  // material name -> its map_Kd line
  for (const Library& lib : libraries) {
    for (const std::string& name : lib.lines.defined) defined_in.emplace(name, lib.path);
    for (const auto& [name, line] : lib.lines.map_kd_line) texture_line[name] = line;
  }
  std::string library_list;
  for (const detail::ObjReference& lib : refs.libraries)
    library_list += (library_list.empty() ? "" : ", ") + lib.name;
  for (const detail::ObjReference& use : refs.uses)
    if (!defined_in.count(use.name))
      warn(detail::obj_where(path, use.line) + "usemtl " + use.name +
           (refs.libraries.empty() ? ": the file names no material library (mtllib)"
                                   : ": no material of that name in " + library_list) +
           "; the default material is used");

  std::map<std::string, int> texture_of_file;
  for (const tinyobj::material_t& m : materials) {
    auto lib = defined_in.find(m.name);
    std::string mtl_path = lib == defined_in.end() ? path : lib->second;
    Material<T> material = detail::material_from_mtl<T>(m, mtl_path + ": ");
    if (!m.diffuse_texname.empty()) {
      std::string file = detail::resolve_beside(mtl_path, m.diffuse_texname);
      auto known = texture_of_file.find(file);
      if (known != texture_of_file.end()) {
        material.texture = known->second;
      } else {
        try {
          model.textures.push_back(load_texture<T>(file, options.texture_limits));
          material.texture = static_cast<int>(model.textures.size()) - 1;
          texture_of_file[file] = material.texture;
        } catch (const Error& e) {
          warn(detail::obj_where(mtl_path, texture_line[m.name]) + "map_Kd " + m.diffuse_texname +
               ": " + e.what() + "; material " + m.name + " is not textured");
        }
      }
    }
    model.materials.push_back(material);
    model.material_names.push_back(m.name);
  }
  return model;
}

}  // namespace io
}  // namespace twinray

#endif  // TWINRAY_WITH_TINYOBJLOADER
