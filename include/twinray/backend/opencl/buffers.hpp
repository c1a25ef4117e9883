// OpenCL buffers of one backend: the scene's arrays (uploaded once per scene), the
// frame's parameters and lights (a few hundred bytes, written every render), and the
// framebuffer and adaptive-sampling scratch (grown as needed, never shrunk).
// Each triangle's index in its mesh (PackedScene::triangle_faces) is read by ray
// queries alone: it goes to the device at the first query on the scene, never for a
// render, whose kernels get a 16-byte placeholder in its place.
//
// A CPU device shares the host's memory: there the scene's arrays and the framebuffer
// are not copied but wrapped (CL_MEM_USE_HOST_PTR), so the device reads the packed
// scene in place and writes the image where the caller gets it. On PoCL's CPU device
// this saves one copy of the scene and of the framebuffer.
#pragma once

#include <array>
#include <string>

#include <twinray/backend/opencl/context.hpp>
#include <twinray/pack/pack.hpp>

namespace twinray {
namespace opencl {

// A device buffer that owns its cl_mem and grows on demand.
class Buffer {
 public:
  Buffer() = default;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  ~Buffer() { release(); }

  cl_mem mem() const { return mem_; }
  // Bytes of data it holds: the last write() or wrap(); 0 after reserve() alone.
  size_t bytes() const { return bytes_; }

  // At least `bytes` of storage (OpenCL has no empty buffers: 16 bytes at least);
  // contents undefined after a reallocation.
  void reserve(cl_context context, cl_mem_flags flags, size_t bytes, const char* what) {
    size_t want = bytes > 0 ? bytes : 16;
    if (mem_ && capacity_ >= want) return;
    release();
    cl_int err = CL_SUCCESS;
    mem_ = clCreateBuffer(context, flags, want, nullptr, &err);
    check(err, what);
    capacity_ = want;
    bytes_ = 0;
  }

  // Wraps `bytes` of host memory at `data` (CL_MEM_USE_HOST_PTR): the device uses that
  // memory itself, and it must outlive the buffer (or the next wrap() or reserve()).
  // No bytes: a private 16-byte buffer, since OpenCL has no empty buffers.
  void wrap(cl_context context, cl_mem_flags flags, void* data, size_t bytes, const char* what) {
    release();
    if (bytes == 0) return reserve(context, flags, 0, what);
    cl_int err = CL_SUCCESS;
    mem_ = clCreateBuffer(context, flags | CL_MEM_USE_HOST_PTR, bytes, data, &err);
    check(err, what);
    bytes_ = bytes;
    // capacity_ stays 0: the memory is the caller's, so a later reserve() or write()
    // makes a buffer of its own instead of writing into it.
  }

  // Writes `bytes` from `data` to the start, growing the buffer first when needed.
  void write(const Context& ctx, cl_mem_flags flags, const void* data, size_t bytes,
             const char* what) {
    reserve(ctx.context(), flags, bytes, what);
    if (bytes > 0)
      check(clEnqueueWriteBuffer(ctx.queue(), mem_, CL_TRUE, 0, bytes, data, 0, nullptr, nullptr),
            "clEnqueueWriteBuffer");
    bytes_ = bytes;
  }

  // Writes bytes [from, bytes) of `data` at the same offset, where the buffer is its
  // own, large enough and holds bytes [0, from) already (written before, unchanged);
  // else all of it, as write(), into a buffer with `headroom` bytes to spare for the
  // next time. Returns the bytes sent.
  size_t write_from(const Context& ctx, cl_mem_flags flags, const void* data, size_t bytes,
                    size_t from, size_t headroom, const char* what) {
    if (!(mem_ && capacity_ >= bytes && bytes_ >= from && from <= bytes)) {
      reserve(ctx.context(), flags, bytes + headroom, what);
      write(ctx, flags, data, bytes, what);
      return bytes;
    }
    if (bytes > from)
      check(clEnqueueWriteBuffer(ctx.queue(), mem_, CL_TRUE, from, bytes - from,
                                 static_cast<const char*>(data) + from, 0, nullptr, nullptr),
            "clEnqueueWriteBuffer");
    bytes_ = bytes;
    return bytes - from;
  }

  void release() {
    if (mem_) clReleaseMemObject(mem_);
    mem_ = nullptr;
    capacity_ = 0;
    bytes_ = 0;
  }

 private:
  cl_mem mem_ = nullptr;
  size_t capacity_ = 0;
  size_t bytes_ = 0;
};

// The buffers every kernel in kernels/render.cl takes as its first arguments, in this
// order: params, spheres, triangles, planes, materials, lights, bvh_nodes, bvh_prims,
// triangle_attrs, textures, texels, object_masks, triangle_faces (a placeholder until
// a query needs it: SceneBuffers::upload_faces), instances.
constexpr cl_uint kSceneArgs = 14;

class SceneBuffers {
 public:
  // The scene's arrays, sent once per scene; or, with `in_place` (a device that shares
  // the host's memory), wrapped where they are: then `ps` must outlive the buffers.
  // All but triangle_faces, which only queries read (upload_faces): its buffer becomes
  // a 16-byte placeholder until then.
  template <class T>
  void upload_scene(const Context& ctx, const PackedScene<T>& ps, bool in_place) {
    auto put = [&](Buffer& b, const auto& v) {
      put_bytes(ctx, b, v.data(), v.size() * sizeof(v[0]), in_place);
    };
    put(spheres_, ps.spheres);
    put(triangles_, ps.triangles);
    put(planes_, ps.planes);
    put(materials_, ps.materials);
    if (!in_place && ps.instance_root >= 0)  // room for the moved top levels to come
      bvh_nodes_.reserve(ctx.context(), CL_MEM_READ_ONLY,
                         2 * ps.bvh_nodes.bytes() - ps.top_level_offset(), "clCreateBuffer (BVH)");
    put_bytes(ctx, bvh_nodes_, ps.bvh_nodes.data(), ps.bvh_nodes.bytes(), in_place);
    put(bvh_prims_, ps.bvh_prims);
    put(triangle_attrs_, ps.triangle_attrs);
    put(textures_, ps.textures);
    put(texels_, ps.texels);
    put(object_masks_, ps.object_masks);
    put(instances_, ps.instances);
    triangle_faces_.release();  // a larger buffer of the last scene's would stay otherwise
    triangle_faces_.reserve(ctx.context(), CL_MEM_READ_ONLY, 0,
                            "clCreateBuffer (triangle faces placeholder)");
    has_faces_ = false;
  }

  // The scene these buffers hold, after update_instances (pack.hpp) moved its instances
  // in place: only the top level's nodes (node ps.instance_root on) and the instance
  // array go again; the assets' nodes and every other array stay. In place, those two
  // are wrapped again (their storage may have moved).
  template <class T>
  void upload_top_level(const Context& ctx, const PackedScene<T>& ps, bool in_place) {
    const size_t from = ps.top_level_offset(), bytes = ps.bvh_nodes.bytes();
    // A top level that outgrows the buffer sends the whole tree, into room for one twice
    // as large, so that the next frames' top levels fit.
    if (in_place)
      put_bytes(ctx, bvh_nodes_, ps.bvh_nodes.data(), bytes, true);
    else
      bytes_sent_ += bvh_nodes_.write_from(ctx, CL_MEM_READ_ONLY, ps.bvh_nodes.data(), bytes, from,
                                           bytes - from, "clCreateBuffer (BVH)");
    put_bytes(ctx, instances_, ps.instances.data(), ps.instances.size() * sizeof(ps.instances[0]),
              in_place);
  }

  // Bytes of scene arrays copied to the device so far (wrapped arrays count nothing).
  size_t bytes_sent() const { return bytes_sent_; }

  // Each triangle's index in its mesh (PackedScene::triangle_faces), for ray queries:
  // sent, or wrapped with `in_place` (then `faces` must outlive the buffers), once per
  // scene. Whether it was sent now.
  bool upload_faces(const Context& ctx, const int* faces, size_t count, bool in_place) {
    if (has_faces_) return false;
    put_bytes(ctx, triangle_faces_, faces, count * sizeof(int), in_place);
    has_faces_ = true;
    return true;
  }
  // Whether the device holds the scene's triangle_faces (upload_faces).
  bool has_faces() const { return has_faces_; }

  // Bytes of the scene's arrays the device holds, copied or wrapped (without the
  // parameters and lights): PackedScene::bytes(), less triangle_faces until a query.
  size_t scene_bytes() const {
    size_t total = 0;
    for (const Buffer* b :
         {&spheres_, &triangles_, &planes_, &materials_, &bvh_nodes_, &bvh_prims_, &triangle_attrs_,
          &textures_, &texels_, &object_masks_, &triangle_faces_, &instances_})
      total += b->bytes();
    return total;
  }

  // The parameters of ray queries (query_params); no lights.
  template <class Params>
  void upload_params(const Context& ctx, const Params& params) {
    params_.write(ctx, CL_MEM_READ_ONLY, &params, sizeof params, "clCreateBuffer (parameters)");
    lights_.reserve(ctx.context(), CL_MEM_READ_ONLY, 0, "clCreateBuffer (lights)");
  }

  // A render's parameters and lights.
  template <class T>
  void upload_frame(const Context& ctx, const PackedFrame<T>& frame) {
    params_.write(ctx, CL_MEM_READ_ONLY, &frame.params, sizeof frame.params,
                  "clCreateBuffer (parameters)");
    lights_.write(ctx, CL_MEM_READ_ONLY, frame.lights.data(),
                  frame.lights.size() * sizeof(frame.lights[0]), "clCreateBuffer (lights)");
  }

  std::array<cl_mem, kSceneArgs> args() const {
    return {params_.mem(),         spheres_.mem(),       triangles_.mem(), planes_.mem(),
            materials_.mem(),      lights_.mem(),        bvh_nodes_.mem(), bvh_prims_.mem(),
            triangle_attrs_.mem(), textures_.mem(),      texels_.mem(),    object_masks_.mem(),
            instances_.mem(),      triangle_faces_.mem()};
  }
  cl_mem params() const { return params_.mem(); }

 private:
  void put_bytes(const Context& ctx, Buffer& b, const void* data, size_t bytes, bool in_place) {
    if (in_place) {  // read-only on both sides: the const_cast only meets the C API
      b.wrap(ctx.context(), CL_MEM_READ_ONLY, const_cast<void*>(data), bytes,
             "clCreateBuffer (scene data, host memory)");
    } else {
      b.write(ctx, CL_MEM_READ_ONLY, data, bytes, "clCreateBuffer (scene data)");
      bytes_sent_ += bytes;
    }
  }

  Buffer params_, spheres_, triangles_, planes_, materials_, lights_, bvh_nodes_, bvh_prims_,
      triangle_attrs_, textures_, texels_, object_masks_, triangle_faces_, instances_;
  bool has_faces_ = false;
  size_t bytes_sent_ = 0;
};

}  // namespace opencl
}  // namespace twinray
