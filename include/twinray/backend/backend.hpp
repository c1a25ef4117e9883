// The backend interface: one contract that the CPU and the OpenCL backend implement.
//
// A backend is made once per device (make_backend, backend/render.hpp). It takes a
// packed scene, uploads it once and keeps it until the next set_scene(). Each render()
// takes a RenderRequest (pack/pack.hpp): camera, lights, options and a pixel
// rectangle. The options carry the sample plan (options.spp with the sampler, and
// options.adaptive_spp for adaptive sampling) and the output (the shaded image or one
// AOV). A frame that changes only the camera, the lights or the options repacks and
// re-uploads nothing of the scene.
//
//   auto backend = twinray::make_backend<float>(options);
//   backend->set_scene(twinray::share(twinray::pack_scene(scene, backend->pack_options())));
//   twinray::Image<float> image;
//   for (int frame = 0; frame < 100; ++frame) {
//     camera.position = orbit(frame);
//     backend->render_into({camera, scene.lights, options}, image);  // reuses its storage
//   }
//
// Guarantees of every backend:
//  - The same request gives the same bits on every backend (PoCL's CPU device here;
//    docs/architecture.md, "Bitwise parity").
//  - The pixels of a rectangle are bit-identical to the same pixels of a whole-frame
//    render, adaptive sampling included.
//  - A backend object is used from one thread at a time; several objects may render at
//    once (OpenCL objects on one device take turns on its queue).
//
// Ray queries (docs/ray-queries.md): the same backend answers the user's own rays, a
// batch of any size at a time, with the same bits on every backend, batch size, ray
// order, thread count, BVH width and ISA:
//   std::vector<twinray::Ray<float>> rays(n);  // origin, direction, tmin, tmax, mask
//   std::vector<twinray::Hit<float>> hits(n);  // t, u, v, normal, object, primitive
//   backend->intersect(rays.data(), n, hits.data());      // closest hit
//   std::vector<uint8_t> blocked(n);
//   backend->occluded(rays.data(), n, blocked.data());    // any hit in [tmin, tmax]
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/pack/pack.hpp>

namespace twinray {

// A ray of a query (device/types.h, TrQueryRay): fields ox, oy, oz (origin), dx, dy, dz
// (direction, any nonzero length: t counts its lengths), tmin, tmax (hits are looked for
// in [tmin, tmax], t > 0) and mask (objects whose mask shares no bit with it are
// skipped). make_ray() fills one from vectors.
template <class T>
using Ray = typename device::Code<T>::QueryRay;
// The closest hit of a query ray (TrQueryHit): t, u, v, nx, ny, nz (the unit
// geometric normal, facing the ray's origin), object (index in Scene::objects) and
// primitive (the triangle's index in its mesh; 0 for other shapes), instance (-1). A
// hit inside an instance: instance is the instance's index in Scene::objects and object
// the object's index in its asset (as Embree's instID and geomID). A miss: t = +inf,
// object = primitive = instance = -1.
template <class T>
using Hit = typename device::Code<T>::QueryHit;
// What intersect() adds on request (TrQueryExtras): snx, sny, snz (the unit shading
// normal, on the geometric normal's side) and tex_u, tex_v (texture coordinates).
template <class T>
using HitExtra = typename device::Code<T>::QueryExtras;

// Which extras intersect() computes (flags; or them together).
enum class HitExtras : unsigned {
  None = 0,
  ShadingNormal = TR_QUERY_SHADING_NORMAL,
  TextureUv = TR_QUERY_TEXTURE_UV,
};
inline HitExtras operator|(HitExtras a, HitExtras b) {
  return static_cast<HitExtras>(static_cast<unsigned>(a) | static_cast<unsigned>(b));
}

// A query ray from origin o along d, with hits looked for in [tmin, tmax].
template <class T>
Ray<T> make_ray(const glm::vec<3, T>& o, const glm::vec<3, T>& d, T tmin = T(0),
                T tmax = T(INFINITY), uint32_t mask = 0xffffffffu) {
  Ray<T> r{};
  r.ox = o.x, r.oy = o.y, r.oz = o.z;
  r.dx = d.x, r.dy = d.y, r.dz = d.z;
  r.tmin = tmin, r.tmax = tmax;
  r.mask = mask;
  return r;
}

template <class T>
class RenderBackend {
 public:
  virtual ~RenderBackend() = default;

  // Which backend this is (Cpu or OpenCL) and the device it runs on.
  virtual Backend kind() const = 0;
  virtual std::string device_name() const = 0;

  // How to pack a scene for this backend: the BVH width measured fastest on it. Any
  // packed scene renders to the same bits on any backend; this is speed only.
  virtual PackOptions pack_options() const { return PackOptions{}; }

  // The scene to render from now on. The backend keeps the pointer (the CPU reads the
  // arrays in place) or uploads the arrays at the next render and lets it go (OpenCL).
  virtual void set_scene(std::shared_ptr<const PackedScene<T>> scene) = 0;

  // The same, for the scene set last after update_instances() (pack/pack.hpp) moved its
  // instances in place: a backend that copies the scene to its device sends only the
  // top level and the instances again, not the assets. Any other scene is set whole.
  virtual void set_moved_instances(std::shared_ptr<const PackedScene<T>> scene) {
    set_scene(std::move(scene));
  }

  // Renders the request against the scene into `image`, which becomes rect.width x
  // rect.height (the whole frame by default); every pixel is written. The image's
  // storage is reused where it is large enough, so a frame loop that passes the same
  // image every frame neither allocates nor zeroes a framebuffer (25 MB at 1920x1080
  // in float). Throws InvalidInput for a bad request or when no scene was set (the
  // image is left as it was); BackendUnavailable or RuntimeFailure from the device
  // (the image may be partly written).
  virtual void render_into(const RenderRequest<T>& request, Image<T>& image,
                           RenderInfo* info = nullptr) = 0;

  // The same into a new image.
  Image<T> render(const RenderRequest<T>& request, RenderInfo* info = nullptr) {
    Image<T> image;
    render_into(request, image, info);
    return image;
  }

  // The closest hit of each of the n rays against the scene: hits[i] for rays[i]
  // (device/ray_query.h). With `extras`, also extra_out[i] (fields not asked for are
  // 0). A ray that is not valid (a direction of zero, a coordinate that is NaN or
  // infinite, tmin infinite or NaN, tmax < tmin or tmax < 0) gets a miss. Any n; the
  // batch goes through in chunks, with no copy of the whole of it. Throws InvalidInput
  // for null arrays with n > 0, extras without extra_out, or no scene.
  void intersect(const Ray<T>* rays, size_t n, Hit<T>* hits, HitExtras extras = HitExtras::None,
                 HitExtra<T>* extra_out = nullptr) {
    const unsigned flags = static_cast<unsigned>(extras);
    if (flags & ~unsigned(TR_QUERY_SHADING_NORMAL | TR_QUERY_TEXTURE_UV))
      throw invalid_input("intersect: unknown HitExtras bits " + std::to_string(flags));
    if (n > 0 && (!rays || !hits))
      throw invalid_input("intersect: null rays or hits for " + std::to_string(n) + " rays");
    if (n > 0 && flags != 0 && !extra_out)
      throw invalid_input("intersect: extras asked for, but extra_out is null");
    intersect_rays(rays, n, hits, flags, extra_out);
  }

  // Whether anything lies on each ray within [tmin, tmax]: blocked[i] = 1 exactly when
  // intersect() would find a hit for rays[i], else 0 (a ray that is not valid: 0).
  void occluded(const Ray<T>* rays, size_t n, uint8_t* blocked) {
    if (n > 0 && (!rays || !blocked))
      throw invalid_input("occluded: null rays or blocked for " + std::to_string(n) + " rays");
    occluded_rays(rays, n, blocked);
  }

 protected:
  // What intersect() and occluded() run once their arguments are checked.
  virtual void intersect_rays(const Ray<T>* rays, size_t n, Hit<T>* hits, unsigned extras,
                              HitExtra<T>* extra_out) = 0;
  virtual void occluded_rays(const Ray<T>* rays, size_t n, uint8_t* blocked) = 0;
};

// A packed scene as set_scene() takes it.
template <class T>
std::shared_ptr<const PackedScene<T>> share(PackedScene<T>&& scene) {
  return std::make_shared<const PackedScene<T>>(std::move(scene));
}

// Helpers the backends share: the adaptive sample plan's host steps and timings.
namespace sample_plan {

// Camera samples an adaptive render traces: spp everywhere, plus the refinement's
// (the R2 sampler continues the first pass; the others start the pixel again).
inline long long samples_traced(const RenderOptions& o, long long pixels, long long refined) {
  if (o.adaptive_spp == 0 || o.output != Output::Shaded) return pixels * o.spp;
  long long extra = o.sampler == Sampler::R2 ? o.adaptive_spp - o.spp : o.adaptive_spp;
  return pixels * o.spp + refined * extra;
}

// Indices of the flagged pixels, in order.
inline std::vector<int> flagged_pixels(const std::vector<int>& flags) {
  std::vector<int> list;
  for (size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) list.push_back(static_cast<int>(i));
  return list;
}

inline double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace sample_plan

// Throws InvalidInput when a backend is asked to render before it has a scene.
// The device code's number for an AOV (TR_AOV_*, device/trace.h).
inline int device_aov(Output output) {
  switch (output) {
    case Output::Depth:
      return TR_AOV_DEPTH;
    case Output::Normal:
      return TR_AOV_NORMAL;
    case Output::ShadingNormal:
      return TR_AOV_SHADING_NORMAL;
    case Output::Uv:
      return TR_AOV_UV;
    default:
      return TR_AOV_OBJECT;
  }
}

inline void require_scene(bool has_scene) {
  if (!has_scene)
    throw invalid_input("render: no scene; call set_scene() with a packed scene first");
}

}  // namespace twinray
