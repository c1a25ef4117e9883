// twinray._core: the extension module under the Python package twinray
// (python/twinray/__init__.py holds the public API and checks its arguments).
// twinray::Error becomes ValueError for bad input and RuntimeError for everything else.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/array.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <twinray/backend/render.hpp>
#include <twinray/io/pfm.hpp>
#include <twinray/io/png.hpp>
#include <twinray/version.hpp>

#include "native_scene.hpp"
#include "native_types.hpp"

namespace nb = nanobind;
using namespace twinray_python;

namespace twinray_python {
void bind_tracer_float(nb::module_& m);
void bind_tracer_double(nb::module_& m);
}  // namespace twinray_python

namespace {

glm::dvec3 dvec(const Vec3& v) {
  return {v[0], v[1], v[2]};
}

// A 4x4 row-major matrix as the scene format writes it, or none.
std::optional<twinray::Transform> transform_of(const std::optional<std::array<double, 16>>& rows) {
  if (!rows) return std::nullopt;
  double m[4][4];
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[r][c] = (*rows)[static_cast<size_t>(r * 4 + c)];
  try {
    return twinray::Transform::from_rows(m);
  } catch (const twinray::Error& e) {
    throw twinray::invalid_input(std::string("transform: ") + e.what());
  }
}

// An (h, w, 3) image of T from Python, as the library's Image.
template <class T>
twinray::Image<T> image_of(
    const nb::ndarray<const T, nb::shape<-1, -1, 3>, nb::c_contig, nb::device::cpu>& a) {
  twinray::Image<T> image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
  std::copy(a.data(), a.data() + a.size(), image.rgb.begin());
  return image;
}

template <class T>
void bind_writers(nb::module_& m) {
  using Array = nb::ndarray<const T, nb::shape<-1, -1, 3>, nb::c_contig, nb::device::cpu>;
  m.def("write_png", [](const std::string& path, const Array& a) {
    twinray::Image<T> image = image_of(a);
    nb::gil_scoped_release release;
    twinray::io::write_png(path, image);
  });
  m.def("write_pfm", [](const std::string& path, const Array& a) {
    twinray::Image<T> image = image_of(a);
    nb::gil_scoped_release release;
    twinray::io::write_pfm(path, image);
  });
}

}  // namespace

NB_MODULE(_core, m) {
  m.doc() = "twinray's C++ engine; use the package twinray, not this module";
  m.attr("__version__") = TWINRAY_VERSION_STRING;

  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const twinray::Error& e) {
      PyErr_SetString(
          e.kind() == twinray::ErrorKind::InvalidInput ? PyExc_ValueError : PyExc_RuntimeError,
          e.what());
    }
  });

  nb::class_<CameraSpec>(m, "Camera")
      .def(nb::init<>())
      .def_rw("position", &CameraSpec::position)
      .def_rw("look_at", &CameraSpec::look_at)
      .def_rw("up", &CameraSpec::up)
      .def_rw("projection", &CameraSpec::projection)
      .def_rw("viewplane_height", &CameraSpec::viewplane_height)
      .def_rw("focal_length", &CameraSpec::focal_length)
      .def_rw("width", &CameraSpec::width)
      .def_rw("height", &CameraSpec::height);

  nb::class_<LightSpec>(m, "Light")
      .def(nb::init<>())
      .def_rw("position", &LightSpec::position)
      .def_rw("intensity", &LightSpec::intensity)
      .def_rw("color", &LightSpec::color)
      .def_rw("shape", &LightSpec::shape)
      .def_rw("edge1", &LightSpec::edge1)
      .def_rw("edge2", &LightSpec::edge2)
      .def_rw("radius", &LightSpec::radius)
      .def_rw("samples", &LightSpec::samples);

  nb::class_<RenderSpec>(m, "RenderSpec")
      .def(nb::init<>())
      .def_rw("spp", &RenderSpec::spp)
      .def_rw("max_depth", &RenderSpec::max_depth)
      .def_rw("shadows", &RenderSpec::shadows)
      .def_rw("glaze", &RenderSpec::glaze)
      .def_rw("seed", &RenderSpec::seed)
      .def_rw("sampler", &RenderSpec::sampler)
      .def_rw("aov", &RenderSpec::aov);

  nb::class_<NativeScene>(m, "Scene")
      .def(nb::init<>())
      .def("load", &NativeScene::load)
      .def("add_material",
           [](NativeScene& s, const Vec3& color, double ka, double kd, double ks, double shininess,
              double glaze, double transmission, double ior, const Vec3& absorption) {
             twinray::Material<double> mat;
             mat.color = dvec(color);
             mat.ka = ka, mat.kd = kd, mat.ks = ks, mat.shininess = shininess, mat.glaze = glaze;
             mat.transmission = transmission, mat.ior = ior, mat.absorption = dvec(absorption);
             return s.add_material(mat);
           })
      .def("add_asset", &NativeScene::add_asset)
      .def("add_instance",
           [](NativeScene& s, int asset, int material, uint32_t mask,
              std::optional<std::array<double, 16>> transform) {
             twinray::Instance<double> in;
             in.asset = asset;
             in.material = material;
             in.mask = mask;
             return s.add_object(in, transform_of(transform));
           })
      .def("add_sphere",
           [](NativeScene& s, const Vec3& center, double radius, int material, uint32_t mask,
              std::optional<std::array<double, 16>> transform, int asset) {
             return s.add_object(twinray::Sphere<double>{dvec(center), radius, material, mask},
                                 transform_of(transform), asset);
           })
      .def("add_plane",
           [](NativeScene& s, const Vec3& point, const Vec3& normal, int material, uint32_t mask,
              std::optional<std::array<double, 16>> transform) {
             return s.add_object(twinray::Plane<double>{dvec(point), dvec(normal), material, mask},
                                 transform_of(transform));
           })
      .def("add_triangle",
           [](NativeScene& s, const Vec3& a, const Vec3& b, const Vec3& c, int material,
              uint32_t mask, std::optional<std::array<double, 16>> transform, int asset) {
             twinray::Triangle<double> t;
             t.vertices = {dvec(a), dvec(b), dvec(c)};
             t.material = material;
             t.mask = mask;
             return s.add_object(t, transform_of(transform), asset);
           })
      .def("add_mesh",
           [](NativeScene& s,
              const nb::ndarray<const double, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>& v,
              const nb::ndarray<const int64_t, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>& t,
              int material, uint32_t mask, std::optional<std::array<double, 16>> transform,
              int asset) {
             twinray::Mesh<double> mesh;
             mesh.vertices.resize(v.shape(0));
             for (size_t i = 0; i < v.shape(0); ++i)
               mesh.vertices[i] = {v.data()[3 * i], v.data()[3 * i + 1], v.data()[3 * i + 2]};
             const std::string path = twinray::detail::at("objects", s.object_count());
             if (mesh.vertices.size() < 3)
               throw twinray::invalid_input(path + ".vertices: must hold at least 3 points, got " +
                                            std::to_string(mesh.vertices.size()));
             if (t.shape(0) == 0)
               throw twinray::invalid_input(path +
                                            ".triangles: must hold at least one index "
                                            "triple, got none");
             mesh.triangles.resize(t.shape(0));
             const long long n = static_cast<long long>(mesh.vertices.size());
             for (size_t f = 0; f < t.shape(0); ++f)
               for (size_t k = 0; k < 3; ++k) {
                 const long long index = t.data()[3 * f + k];
                 if (index < 0 || index >= n)
                   throw twinray::invalid_input(
                       path + ".triangles[" + std::to_string(f) + "][" + std::to_string(k) +
                       "]: vertex index " + std::to_string(index) + " out of range: the mesh has " +
                       std::to_string(n) + " vertices (indices 0 to " + std::to_string(n - 1) +
                       ")");
                 mesh.triangles[f][k] = static_cast<int>(index);
               }
             mesh.material = material;
             mesh.mask = mask;
             return s.add_object(std::move(mesh), transform_of(transform), asset);
           })
      .def("add_obj",
           [](NativeScene& s, const std::string& path, int material, uint32_t mask,
              std::optional<std::array<double, 16>> transform, int asset) {
             int index = -1;
             std::vector<std::string> warnings =
                 s.add_obj(path, material, transform_of(transform), mask, &index, asset);
             return std::make_pair(index, warnings);
           })
      .def_prop_rw(
          "background", [](const NativeScene& s) { return from_vec(s.background()); },
          [](NativeScene& s, const Vec3& c) { s.set_background(dvec(c)); })
      .def("set_environment",
           [](NativeScene& s, const std::string& path, double rotate_degrees, double intensity,
              const Vec3& up) { s.set_environment(path, rotate_degrees, intensity, dvec(up)); })
      .def_prop_ro("environment_file", &NativeScene::environment_file)
      .def_prop_ro("material_count", &NativeScene::material_count)
      .def_prop_ro("object_count", &NativeScene::object_count)
      .def_prop_ro("asset_count", &NativeScene::asset_count)
      .def_prop_ro("version", &NativeScene::version)
      .def_prop_ro("file_camera",
                   [](const NativeScene& s) { return CameraSpec::from(s.file().camera); })
      .def_prop_ro("file_lights",
                   [](const NativeScene& s) {
                     std::vector<LightSpec> lights;
                     for (const auto& l : s.file().scene.lights)
                       lights.push_back(LightSpec::from(l));
                     return lights;
                   })
      .def_prop_ro("file_warnings", [](const NativeScene& s) { return s.file().warnings; });

  bind_tracer_float(m);
  bind_tracer_double(m);
  bind_writers<float>(m);
  bind_writers<double>(m);

  m.def("opencl_available", [](int device) {
    std::string why;
    bool ok = twinray::opencl_available(device, &why);
    return std::make_pair(ok, why);
  });
}
