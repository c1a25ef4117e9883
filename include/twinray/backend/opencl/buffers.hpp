// OpenCL buffers of one backend: the scene's arrays (uploaded once per scene), the
// frame's parameters and lights (a few hundred bytes, written every render), and the
// framebuffer and adaptive-sampling scratch (grown as needed, never shrunk).
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
  }

  void release() {
    if (mem_) clReleaseMemObject(mem_);
    mem_ = nullptr;
    capacity_ = 0;
  }

 private:
  cl_mem mem_ = nullptr;
  size_t capacity_ = 0;
};

// The buffers every kernel in kernels/render.cl takes as its first arguments, in this
// order: params, spheres, triangles, planes, materials, lights, bvh_nodes, bvh_prims,
// triangle_attrs, textures, texels, object_masks, triangle_faces.
constexpr cl_uint kSceneArgs = 13;

class SceneBuffers {
 public:
  // The scene's arrays, sent once per scene; or, with `in_place` (a device that shares
  // the host's memory), wrapped where they are: then `ps` must outlive the buffers.
  template <class T>
  void upload_scene(const Context& ctx, const PackedScene<T>& ps, bool in_place) {
    auto put_bytes = [&](Buffer& b, const void* data, size_t bytes) {
      if (in_place)  // read-only on both sides: the const_cast only meets the C API
        b.wrap(ctx.context(), CL_MEM_READ_ONLY, const_cast<void*>(data), bytes,
               "clCreateBuffer (scene data, host memory)");
      else
        b.write(ctx, CL_MEM_READ_ONLY, data, bytes, "clCreateBuffer (scene data)");
    };
    auto put = [&](Buffer& b, const auto& v) { put_bytes(b, v.data(), v.size() * sizeof(v[0])); };
    put(spheres_, ps.spheres);
    put(triangles_, ps.triangles);
    put(planes_, ps.planes);
    put(materials_, ps.materials);
    put_bytes(bvh_nodes_, ps.bvh_nodes.data(), ps.bvh_nodes.bytes());
    put(bvh_prims_, ps.bvh_prims);
    put(triangle_attrs_, ps.triangle_attrs);
    put(textures_, ps.textures);
    put(texels_, ps.texels);
    put(object_masks_, ps.object_masks);
    put(triangle_faces_, ps.triangle_faces);
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
    return {params_.mem(),         spheres_.mem(),  triangles_.mem(), planes_.mem(),
            materials_.mem(),      lights_.mem(),   bvh_nodes_.mem(), bvh_prims_.mem(),
            triangle_attrs_.mem(), textures_.mem(), texels_.mem(),    object_masks_.mem(),
            triangle_faces_.mem()};
  }
  cl_mem params() const { return params_.mem(); }

 private:
  Buffer params_, spheres_, triangles_, planes_, materials_, lights_, bvh_nodes_, bvh_prims_,
      triangle_attrs_, textures_, texels_, object_masks_, triangle_faces_;
};

}  // namespace opencl
}  // namespace twinray
