// NativeTracer<T>: the C++ side of twinray.Tracer in one precision. It owns a backend
// (backend/render.hpp), packs the scene when the scene has changed since the last call,
// and renders, intersects and tests occlusion with the GIL released. The Python layer
// (twinray/__init__.py) hands it arrays already of the right dtype, shape and layout.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <twinray/backend/render.hpp>
#include <twinray/core/parallel.hpp>

#include "native_scene.hpp"
#include "native_types.hpp"

namespace twinray_python {

namespace nb = nanobind;

template <class T>
using In1 = nb::ndarray<const T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using In2 = nb::ndarray<const T, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>;
template <class T>
using Out1 = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using Out2 = nb::ndarray<T, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu>;

// Rays go to the backend in chunks of this many: the batch is read from the caller's
// arrays and the hits written into the caller's arrays a chunk at a time, so a batch of
// any size costs two chunk-sized buffers (2^18 rays: 9 MiB of rays, 8 of hits in float).
constexpr size_t kQueryChunk = size_t(1) << 18;

template <class T>
class NativeTracer {
 public:
  NativeTracer(const std::string& backend, int device) {
    twinray::RenderOptions o;
    o.backend = backend == "cpu"      ? twinray::Backend::Cpu
                : backend == "opencl" ? twinray::Backend::OpenCL
                                      : twinray::Backend::Auto;
    o.device = device;
    o.log = [this](const std::string& note) { notes_.push_back(note); };
    backend_ = twinray::make_backend<T>(o);
  }

  std::string backend_name() const { return twinray::to_string(backend_->kind()); }
  std::string device() const { return backend_->device_name(); }
  std::vector<std::string> notes() const { return notes_; }

  // Packs the scene unless it is the one packed last.
  void prepare(const NativeScene& scene) {
    if (scene.version() == packed_version_) return;
    twinray::Scene<T> built = scene.build<T>();
    auto packed = twinray::share(twinray::pack_scene(built, backend_->pack_options()));
    nb::gil_scoped_release release;
    backend_->set_scene(std::move(packed));
    packed_version_ = scene.version();
    ++pack_count_;
  }

  long long pack_count() const { return pack_count_; }

  // The frame as (height, width, 3) values of T: the shaded image or the AOV.
  nb::ndarray<nb::numpy, T> render(const NativeScene& scene, const CameraSpec& camera,
                                   const std::vector<LightSpec>& lights, const RenderSpec& spec) {
    prepare(scene);
    twinray::RenderOptions o = scene.file().options;
    o.backend = backend_->kind();
    o.log = [this](const std::string& note) { notes_.push_back(note); };
    spec.apply(o);
    twinray::Camera<T> cam = camera.as<T>();
    std::vector<twinray::Light<T>> lit;
    for (size_t i = 0; i < lights.size(); ++i) lit.push_back(lights[i].as<T>(i));
    twinray::validate(cam);
    twinray::validate_lights(lit);
    twinray::validate(o);
    auto* image = new twinray::Image<T>();
    nb::capsule owner(image, [](void* p) noexcept { delete static_cast<twinray::Image<T>*>(p); });
    {
      nb::gil_scoped_release release;
      backend_->render_into({cam, std::move(lit), o}, *image, &info_);
    }
    return nb::ndarray<nb::numpy, T>(
        image->rgb.data(), {size_t(image->height), size_t(image->width), size_t(3)}, owner);
  }

  // The closest hit of each ray; tmin, tmax and mask hold one value or one per ray.
  void intersect(const NativeScene& scene, In2<T> origins, In2<T> directions, In1<T> tmin,
                 In1<T> tmax, In1<uint32_t> mask, Out1<T> t, Out1<T> u, Out1<T> v, Out2<T> normal,
                 Out1<int32_t> object, Out1<int32_t> primitive, Out1<int32_t> instance) {
    prepare(scene);
    const size_t n = origins.shape(0);
    check_batch(n, directions, tmin, tmax, mask);
    for (size_t size : {t.shape(0), u.shape(0), v.shape(0), normal.shape(0), object.shape(0),
                        primitive.shape(0), instance.shape(0)})
      if (size != n) throw twinray::invalid_input("intersect: an output array is not of n rays");
    nb::gil_scoped_release release;
    std::vector<twinray::Ray<T>> rays(std::min(n, kQueryChunk));
    std::vector<twinray::Hit<T>> hits(rays.size());
    for (size_t begin = 0; begin < n; begin += kQueryChunk) {
      const size_t count = std::min(kQueryChunk, n - begin);
      gather(begin, count, origins, directions, tmin, tmax, mask, rays.data());
      backend_->intersect(rays.data(), count, hits.data());
      twinray::parallel_for_blocks(count, 4096, [&](size_t, size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
          const twinray::Hit<T>& h = hits[i];
          const size_t r = begin + i;
          t.data()[r] = h.t, u.data()[r] = h.u, v.data()[r] = h.v;
          T* nrm = normal.data() + 3 * r;
          nrm[0] = h.nx, nrm[1] = h.ny, nrm[2] = h.nz;
          object.data()[r] = h.object, primitive.data()[r] = h.primitive;
          instance.data()[r] = h.instance;
        }
      });
    }
  }

  // Whether anything lies on each ray within [tmin, tmax] (1) or not (0).
  void occluded(const NativeScene& scene, In2<T> origins, In2<T> directions, In1<T> tmin,
                In1<T> tmax, In1<uint32_t> mask, Out1<uint8_t> blocked) {
    prepare(scene);
    const size_t n = origins.shape(0);
    check_batch(n, directions, tmin, tmax, mask);
    if (blocked.shape(0) != n)
      throw twinray::invalid_input("occluded: the output array is not of n rays");
    nb::gil_scoped_release release;
    std::vector<twinray::Ray<T>> rays(std::min(n, kQueryChunk));
    for (size_t begin = 0; begin < n; begin += kQueryChunk) {
      const size_t count = std::min(kQueryChunk, n - begin);
      gather(begin, count, origins, directions, tmin, tmax, mask, rays.data());
      backend_->occluded(rays.data(), count, blocked.data() + begin);
    }
  }

  // Timings and what ran, of the last render.
  const twinray::RenderInfo& info() const { return info_; }

 private:
  static void check_batch(size_t n, const In2<T>& directions, const In1<T>& tmin,
                          const In1<T>& tmax, const In1<uint32_t>& mask) {
    if (directions.shape(0) != n)
      throw twinray::invalid_input("directions: " + std::to_string(directions.shape(0)) +
                                   " rays, but origins has " + std::to_string(n));
    const char* names[] = {"tmin", "tmax", "mask"};
    const size_t sizes[] = {tmin.shape(0), tmax.shape(0), mask.shape(0)};
    for (int k = 0; k < 3; ++k)
      if (sizes[k] != 1 && sizes[k] != n)
        throw twinray::invalid_input(std::string(names[k]) + ": " + std::to_string(sizes[k]) +
                                     " values; give one, or one per ray (" + std::to_string(n) +
                                     ")");
  }

  // Rays [begin, begin + count) of the caller's arrays, as the backend takes them.
  static void gather(size_t begin, size_t count, const In2<T>& origins, const In2<T>& directions,
                     const In1<T>& tmin, const In1<T>& tmax, const In1<uint32_t>& mask,
                     twinray::Ray<T>* rays) {
    const bool one_tmin = tmin.shape(0) == 1, one_tmax = tmax.shape(0) == 1,
               one_mask = mask.shape(0) == 1;
    twinray::parallel_for_blocks(count, 4096, [&](size_t, size_t b, size_t e) {
      for (size_t i = b; i < e; ++i) {
        const size_t r = begin + i;
        const T* o = origins.data() + 3 * r;
        const T* d = directions.data() + 3 * r;
        twinray::Ray<T>& ray = rays[i];
        ray.ox = o[0], ray.oy = o[1], ray.oz = o[2];
        ray.dx = d[0], ray.dy = d[1], ray.dz = d[2];
        ray.tmin = tmin.data()[one_tmin ? 0 : r];
        ray.tmax = tmax.data()[one_tmax ? 0 : r];
        ray.mask = mask.data()[one_mask ? 0 : r];
      }
    });
  }

  std::unique_ptr<twinray::RenderBackend<T>> backend_;
  long long packed_version_ = 0;
  long long pack_count_ = 0;
  std::vector<std::string> notes_;
  twinray::RenderInfo info_;
};

// Adds the class NativeTracer<T> to the module as `name`.
template <class T>
void bind_tracer(nb::module_& m, const char* name) {
  using Tracer = NativeTracer<T>;
  nb::class_<Tracer>(m, name)
      .def(nb::init<const std::string&, int>(), nb::arg("backend"), nb::arg("device"))
      .def_prop_ro("backend", &Tracer::backend_name)
      .def_prop_ro("device", &Tracer::device)
      .def_prop_ro("notes", &Tracer::notes)
      .def_prop_ro("pack_count", &Tracer::pack_count)
      .def("prepare", &Tracer::prepare)
      .def("render", &Tracer::render)
      .def("intersect", &Tracer::intersect)
      .def("occluded", &Tracer::occluded)
      .def_prop_ro("last_render_ms", [](const Tracer& t) { return t.info().render_ms; })
      .def_prop_ro("last_kernel", [](const Tracer& t) { return t.info().kernel; });
}

}  // namespace twinray_python
