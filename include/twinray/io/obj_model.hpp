// load_obj_model(): an OBJ file with its materials: the mesh (io/obj_mesh.hpp), the
// materials of its `mtllib` libraries, and their `map_Kd` textures (io/texture_image.hpp).
//
// MTL statements read, and how they map onto twinray's Blinn-Phong material
// (scene/material.hpp), whose ambient and diffuse terms share one colour:
//   Kd       -> color (each channel clamped to [0, 1]), kd = 1; without Kd the colour is
//               0.8 grey, or white when the material has a map_Kd (the texture as painted)
//   Ka       -> ka = mean of its channels (default 0)
//   Ks       -> ks = mean of its channels (default 0)
//   Ns       -> shininess (clamped to >= 0; default 1)
//   illum    -> 3 or 5 (reflection on) with a non-zero Ks: glaze = min(1, ks)
//   Tr       -> transmission = Tr (clamped to [0, 1]); else d (dissolve) -> transmission =
//               1 - d; else illum 4, 6 or 7 (glass, refraction) -> transmission = 1. Always
//               at most 1 - glaze (device/dielectric.h)
//   Ni       -> ior, where > 0 (default 1.5)
//   map_Kd   -> texture: the albedo is Kd x the texture at the hit's uv; options before
//               the file name (-s, -o, -clamp, ...) are skipped, the image is used as is
// Colours take one value (grey) or three. Other statements (Tf, bump maps, ...) are
// ignored. A malformed value is an error naming the MTL file and line.
//
// Missing pieces are warnings, as other tools treat them (Blender's importer loads the
// mesh with a default material): a library that cannot be read, a `usemtl` name no
// library defines, a texture file that cannot be read or decoded, a material defined
// twice. Each names the file and line (`spot.obj:2: usemtl red: no material of that name
// in spot.mtl; the default material is used`); `strict` makes them errors. A malformed
// OBJ is always an error.
#pragma once

#include <algorithm>
#include <charconv>
#include <map>
#include <string>
#include <vector>

#include <twinray/io/obj_mesh.hpp>
#include <twinray/io/texture_image.hpp>
#include <twinray/scene/material.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/scene/texture.hpp>

namespace twinray {
namespace io {

template <class T>
struct ObjModel {
  // triangle_materials holds indices into `materials`, or -1 for a triangle with no
  // usable `usemtl` (the caller's default material); it is empty when the file has no
  // `usemtl` line (every triangle takes the default material).
  Mesh<T> mesh;
  std::vector<Material<T>> materials;
  std::vector<std::string> material_names;  // `newmtl` names, as `materials`
  std::vector<Texture<T>> textures;         // Material::texture indexes these
  std::vector<std::string> warnings;        // `file:line: problem; what is used instead`
};

struct ObjModelOptions {
  ObjLimits limits;
  TextureLimits texture_limits;
  bool strict = false;    // warnings are errors
  bool materials = true;  // false: the mesh only; no MTL or texture file is read
};

namespace detail {

inline std::string folder_of(const std::string& path) {
  size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

inline std::string resolve_beside(const std::string& base_file, const std::string& name) {
  return !name.empty() && name[0] == '/' ? name : folder_of(base_file) + name;
}

// One `newmtl` block of an MTL file, as written.
struct MtlMaterial {
  std::string name;
  long long line = 0;  // of its `newmtl`
  double ka[3] = {0, 0, 0}, kd[3] = {0.8, 0.8, 0.8}, ks[3] = {0, 0, 0};
  double ns = 1;
  long long illum = 2;
  double ni = 0, d = 1, tr = 0;  // Ni, d and Tr as written (ni 0: none)
  bool has_d = false, has_tr = false;
  bool has_kd = false;
  std::string map_kd;  // the texture file as written, or empty
  long long map_kd_line = 0;
};

// The options a map_* statement may give before its file name, and how many values
// each takes (-o, -s, -t: one to three numbers).
inline int mtl_option_values(std::string_view option) {
  for (const char* one : {"-blendu", "-blendv", "-clamp", "-cc", "-boost", "-bm", "-texres",
                          "-imfchan", "-type", "-colorspace"})
    if (option == one) return 1;
  if (option == "-mm") return 2;
  if (option == "-o" || option == "-s" || option == "-t") return 3;
  return -1;
}

// Parses MTL text; `name` labels errors (twinray::Error(InvalidInput), `file:line: ...`).
inline std::vector<MtlMaterial> parse_mtl(const std::string& text, const std::string& name) {
  std::vector<MtlMaterial> out;
  ObjSource(text).for_each_line(
      0, static_cast<long long>(text.size()), 1, [&](std::string_view line, long long number) {
        if (std::string binary = obj_binary_byte(line); !binary.empty())
          throw invalid_input(obj_where(name, number) + binary);
        size_t pos = 0;
        std::string_view key;
        if (!next_obj_token(line, pos, key) || key[0] == '#') return;
        if (key == "newmtl") {
          MtlMaterial m;
          m.name = std::string(obj_rest(line, pos));
          m.line = number;
          if (m.name.empty())
            throw invalid_input(obj_where(name, number) + "newmtl needs a material name");
          out.push_back(std::move(m));
          return;
        }
        if (key != "Ka" && key != "Kd" && key != "Ks" && key != "Ns" && key != "illum" &&
            key != "map_Kd" && key != "Ni" && key != "d" && key != "Tr")
          return;  // a statement twinray does not read
        if (out.empty())
          throw invalid_input(obj_where(name, number) + std::string(key) +
                              " before the first newmtl: which material is it for?");
        MtlMaterial& m = out.back();
        std::string_view token[4];
        int count = 0;
        size_t values_at = pos;
        for (std::string_view t; next_obj_token(line, pos, t); ++count)
          if (count < 4) token[count] = t;
        const std::string what = std::string(key) + " value";
        if (key == "Ka" || key == "Kd" || key == "Ks") {
          if (count != 1 && count != 3)
            throw invalid_input(obj_where(name, number) + std::string(key) +
                                " takes 1 value (grey) or 3 (r g b), got " + std::to_string(count) +
                                (count > 0 && (token[0] == "spectral" || token[0] == "xyz")
                                     ? " (spectral and xyz colours are not read)"
                                     : ""));
          double* c = key == "Ka" ? m.ka : key == "Kd" ? m.kd : m.ks;
          for (int k = 0; k < 3; ++k)
            c[k] = obj_number<double>(token[count == 1 ? 0 : k], name, number, what.c_str());
          if (key == "Kd") m.has_kd = true;
        } else if (key == "Ns" || key == "Ni" || key == "Tr") {
          if (count != 1)
            throw invalid_input(obj_where(name, number) + std::string(key) +
                                " takes 1 value, got " + std::to_string(count));
          double v = obj_number<double>(token[0], name, number, what.c_str());
          if (key == "Ns") m.ns = v;
          if (key == "Ni") m.ni = v;
          if (key == "Tr") m.tr = v, m.has_tr = true;
        } else if (key == "d") {  // d [-halo] factor
          int first = count > 0 && token[0] == "-halo" ? 1 : 0;
          if (count != first + 1)
            throw invalid_input(obj_where(name, number) + "d takes 1 value, got " +
                                std::to_string(count - first));
          m.d = obj_number<double>(token[first], name, number, what.c_str());
          m.has_d = true;
        } else if (key == "illum") {
          long long v = -1;
          auto r = std::from_chars(token[0].data(), token[0].data() + token[0].size(), v);
          if (count != 1 || r.ec != std::errc() || r.ptr != token[0].data() + token[0].size() ||
              v < 0 || v > 10)
            throw invalid_input(obj_where(name, number) +
                                "illum takes one model number 0 to 10, got '" +
                                std::string(obj_rest(line, values_at)) + "'");
          m.illum = v;
        } else {  // map_Kd [options] file
          pos = values_at;
          for (std::string_view t;;) {
            size_t at = pos;
            if (!next_obj_token(line, pos, t) || t[0] != '-') {
              pos = at;
              break;
            }
            int values = mtl_option_values(t);
            if (values < 0)
              throw invalid_input(obj_where(name, number) + "map_Kd option '" + std::string(t) +
                                  "' is not an MTL texture option");
            for (int k = 0; k < values; ++k) {
              at = pos;
              if (!next_obj_token(line, pos, t)) break;
              double ignored = 0;
              // -o, -s and -t take one to three numbers: stop at the first that is not.
              if (values == 3 && k > 0 &&
                  std::from_chars(t.data(), t.data() + t.size(), ignored).ptr !=
                      t.data() + t.size()) {
                pos = at;
                break;
              }
            }
          }
          m.map_kd = std::string(obj_rest(line, pos));
          m.map_kd_line = number;
          if (m.map_kd.empty())
            throw invalid_input(obj_where(name, number) + "map_Kd names no texture file");
        }
      });
  for (MtlMaterial& m : out)
    if (!m.has_kd && !m.map_kd.empty()) m.kd[0] = m.kd[1] = m.kd[2] = 1.0;
  return out;
}

template <class T>
Material<T> material_from_mtl(const MtlMaterial& m) {
  Material<T> out;
  for (int k = 0; k < 3; ++k) out.color[k] = static_cast<T>(std::clamp(m.kd[k], 0.0, 1.0));
  out.kd = T(1);
  out.ka = static_cast<T>(std::max(0.0, (m.ka[0] + m.ka[1] + m.ka[2]) / 3.0));
  out.ks = static_cast<T>(std::max(0.0, (m.ks[0] + m.ks[1] + m.ks[2]) / 3.0));
  out.shininess = static_cast<T>(std::max(0.0, m.ns));
  if ((m.illum == 3 || m.illum == 5) && out.ks > T(0)) out.glaze = std::min(T(1), out.ks);
  double transmission = m.has_tr  ? m.tr
                        : m.has_d ? 1.0 - m.d
                                  : (m.illum == 4 || m.illum == 6 || m.illum == 7 ? 1.0 : 0.0);
  out.transmission = std::min(T(1) - out.glaze, static_cast<T>(std::clamp(transmission, 0.0, 1.0)));
  if (m.ni > 0) out.ior = static_cast<T>(m.ni);
  return out;
}

}  // namespace detail

// Loads an OBJ file and what its materials name. Throws twinray::Error(InvalidInput)
// for a malformed OBJ or MTL file, and for a warning when options.strict.
template <class T>
ObjModel<T> load_obj_model(const std::string& path, const ObjModelOptions& options = {}) {
  ObjModel<T> model;
  auto warn = [&](const std::string& message) {
    if (options.strict) throw invalid_input(message + " (--strict)");
    model.warnings.push_back(message);
  };
  detail::ObjSource source(
      path, detail::checked_file_size(path, options.limits.max_file_bytes, "an OBJ file"));
  detail::ObjRead<T> read = detail::read_obj<T>(source, path, options.limits, options.materials);
  model.mesh = std::move(read.mesh);
  if (!options.materials) return model;
  const detail::ObjCounts& refs = read.counts;

  // The libraries' materials, in order; a name defined twice keeps its first definition.
  std::map<std::string, int> index_of;
  std::vector<std::string> material_file;  // the MTL file of each material
  std::vector<detail::MtlMaterial> materials;
  for (const detail::ObjReference& lib : refs.libraries) {
    std::string file = detail::resolve_beside(path, lib.name);
    std::string text;
    try {
      text = detail::read_small_file(file, std::min(options.limits.max_file_bytes, 256ll << 20),
                                     "an MTL file");
    } catch (const Error& e) {
      warn(detail::obj_where(path, lib.line) + "mtllib " + lib.name + ": " + e.what() +
           "; its materials are not used");
      continue;
    }
    for (detail::MtlMaterial& m : detail::parse_mtl(text, file)) {
      auto [at, added] = index_of.emplace(m.name, static_cast<int>(materials.size()));
      if (!added) {
        warn(detail::obj_where(file, m.line) + "newmtl " + m.name + ": defined before, in " +
             material_file[static_cast<size_t>(at->second)] + ":" +
             std::to_string(materials[static_cast<size_t>(at->second)].line) +
             "; this definition is not used");
        continue;
      }
      materials.push_back(std::move(m));
      material_file.push_back(file);
    }
  }

  // Each `usemtl` line's material (-1: the default one).
  std::string library_list;
  for (const detail::ObjReference& lib : refs.libraries)
    library_list += (library_list.empty() ? "" : ", ") + lib.name;
  std::vector<int> material_of_use;
  for (const detail::ObjReference& use : refs.uses) {
    auto found = index_of.find(use.name);
    material_of_use.push_back(found == index_of.end() ? -1 : found->second);
    if (found == index_of.end() && !use.name.empty())
      warn(detail::obj_where(path, use.line) + "usemtl " + use.name +
           (refs.libraries.empty() ? ": the file names no material library (mtllib)"
                                   : ": no material of that name in " + library_list) +
           "; the default material is used");
  }
  for (int& m : model.mesh.triangle_materials)
    m = m < 0 ? -1 : material_of_use[static_cast<size_t>(m)];

  std::map<std::string, int> texture_of_file;
  for (size_t i = 0; i < materials.size(); ++i) {
    const detail::MtlMaterial& m = materials[i];
    Material<T> material = detail::material_from_mtl<T>(m);
    if (!m.map_kd.empty()) {
      std::string file = detail::resolve_beside(material_file[i], m.map_kd);
      auto known = texture_of_file.find(file);
      if (known != texture_of_file.end()) {
        material.texture = known->second;
      } else {
        try {
          model.textures.push_back(load_texture<T>(file, options.texture_limits));
          material.texture = static_cast<int>(model.textures.size()) - 1;
          texture_of_file[file] = material.texture;
        } catch (const Error& e) {
          warn(detail::obj_where(material_file[i], m.map_kd_line) + "map_Kd " + m.map_kd + ": " +
               e.what() + "; material " + m.name + " is not textured");
        }
      }
    }
    model.materials.push_back(material);
    model.material_names.push_back(m.name);
  }
  return model;
}

// Moves a loaded model's textures and materials into `scene` and returns its mesh, with
// each triangle pointing at the scene's copy of its material. Faces without a usable
// `usemtl`, and a file without materials, take one default material (Material<T>{})
// added after the file's. `name` labels the materials in `material_names` when given
// (`spot.obj:cow`, `spot.obj: default material`). Warnings are the caller's to report.
// The scene loader and the Python module's add_obj() both go through here, so a model
// gets the same material indices either way.
template <class T>
Mesh<T> adopt_obj_model(ObjModel<T>&& model, Scene<T>& scene, const std::string& name,
                        std::vector<std::string>* material_names = nullptr) {
  Mesh<T> mesh = std::move(model.mesh);
  const int texture_base = static_cast<int>(scene.textures.size());
  for (Texture<T>& t : model.textures) scene.add_texture(std::move(t));
  std::vector<int> index(model.materials.size());
  for (size_t i = 0; i < model.materials.size(); ++i) {
    Material<T> m = model.materials[i];
    if (m.texture >= 0) m.texture += texture_base;
    index[i] = scene.add_material(m);
    if (material_names) material_names->push_back(name + ":" + model.material_names[i]);
  }
  bool uses_default = mesh.triangle_materials.empty();
  for (int m : mesh.triangle_materials) uses_default = uses_default || m < 0;
  int fallback = -1;
  if (uses_default) {
    fallback = scene.add_material(Material<T>{});
    if (material_names) material_names->push_back(name + ": default material");
  }
  for (int& m : mesh.triangle_materials) m = m < 0 ? fallback : index[static_cast<size_t>(m)];
  mesh.material = mesh.triangle_materials.empty() ? fallback : mesh.triangle_materials[0];
  if (model.materials.empty()) mesh.triangle_materials.clear();
  return mesh;
}

// How many materials adopt_obj_model() adds to a scene for this model.
template <class T>
size_t adopted_material_count(const ObjModel<T>& model) {
  bool uses_default = model.mesh.triangle_materials.empty();
  for (int m : model.mesh.triangle_materials) uses_default = uses_default || m < 0;
  return model.materials.size() + (uses_default ? 1 : 0);
}

}  // namespace io
}  // namespace twinray
