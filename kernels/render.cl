/* twinray OpenCL entry points: thin wrappers around the shared device code.
 * Built with -DTR_FEATURES=<mask> (and -DTR_DOUBLE for double renders), and
 * -DTR_ENTRY_POINTS=<TR_ENTRY_*> for a program that holds one render's kernels only. At build time
 * of the library, cmake/embed_kernels.cmake inlines the quoted includes below, with
 * #line markers, into a C++ header, so no OpenCL driver ever resolves an #include. */
#include "twinray/device/prelude.h"
#include "twinray/device/features.h"
#include "twinray/device/types.h"
#include "twinray/device/functions.h"

#define TR_SCENE_ARGS                                                                    \
  __global const TrParams *params, __global const TrSphere *spheres,                     \
      __global const TrTriangle *triangles, __global const TrPlane *planes,              \
      __global const TrMaterial *materials, __global const TrLight *lights,              \
      __global const real *bvh_nodes, __global const int *bvh_prims,                     \
      __global const TrTriangleAttr *triangle_attrs, __global const TrTexture *textures, \
      __global const real *texels, __global const unsigned int *object_masks,            \
      __global const TrInstance *instances, __global const int *triangle_faces
#define TR_SCENE_ARG_NAMES                                                                     \
  params, spheres, triangles, planes, materials, lights, bvh_nodes, bvh_prims, triangle_attrs, \
      textures, texels, object_masks, instances, triangle_faces

static inline TrSceneRef tr_scene_ref(TR_SCENE_ARGS) {
  TrSceneRef s;
  s.params = params;
  s.spheres = spheres;
  s.triangles = triangles;
  s.planes = planes;
  s.materials = materials;
  s.lights = lights;
  s.bvh_nodes = bvh_nodes;
  s.bvh_prims = bvh_prims;
  s.triangle_attrs = triangle_attrs;
  s.textures = textures;
  s.texels = texels;
  s.object_masks = object_masks;
  s.triangle_faces = triangle_faces;
  s.instances = instances;
  return s;
}

#ifndef TR_ENTRY_POINTS
#define TR_ENTRY_POINTS TR_ENTRY_ALL
#endif
#define TR_HOLDS(entry) (TR_ENTRY_POINTS == TR_ENTRY_ALL || TR_ENTRY_POINTS == (entry))

#if TR_HOLDS(TR_ENTRY_RENDER)
/* One work-item per pixel of the rectangle params->rect_*; the global size is padded
 * to the work-group size. The framebuffer holds the rectangle, row 0 at its top. */
__kernel void tr_kernel_render(TR_SCENE_ARGS, __global real* out) {
  int i = (int)get_global_id(0), j = (int)get_global_id(1);
  if (i >= params->rect_w || j >= params->rect_h) return;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  tr_store_rgb(out, params->rect_w, i, j,
               tr_render_pixel(&s, params->rect_x + i, params->rect_y + j));
}

#endif

#if TR_HOLDS(TR_ENTRY_BLOCKS)
/* One work-item per TR_BLOCK_SIDE^2 block of the rectangle, traced a segment at a time in packets
 * (tr_render_block, as on the CPU backend): for CPU devices, where a work-item is a
 * thread's loop iteration and the packet's shared walk pays as it does in C++. The
 * range is one row of tr_block_count work-items, in tr_tiled_block's order, which the
 * CPU backend's threads follow too. */
__kernel TR_WIDE_VECTORS void tr_kernel_render_blocks(TR_SCENE_ARGS, __global real* out) {
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  TrBlockScratch scratch;
  TrRayStack stacks[TR_HAS(TR_F_DIELECTRIC) ? TR_BLOCK_SIDE * TR_BLOCK_SIDE : 1];
  tr_render_block_at(&s, &scratch, stacks, (int)get_global_id(0), out);
}

#endif

#if TR_HOLDS(TR_ENTRY_AOV)
__kernel void tr_kernel_aov(TR_SCENE_ARGS, __global real* out, int aov) {
  int i = (int)get_global_id(0), j = (int)get_global_id(1);
  if (i >= params->rect_w || j >= params->rect_h) return;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  tr_store_rgb(out, params->rect_w, i, j,
               tr_render_aov(&s, params->rect_x + i, params->rect_y + j, aov));
}

#endif

#if TR_HOLDS(TR_ENTRY_ADAPTIVE)
/* Adaptive sampling (device/adaptive.h), three launches. First pass, every pixel of
 * the statistics window: p->spp samples; sum and range go to `stats`, and the mean to
 * the framebuffer for the pixels of the rectangle. */
__kernel void tr_kernel_adaptive_first(TR_SCENE_ARGS, __global real* out, __global real* stats) {
  int i = (int)get_global_id(0), j = (int)get_global_id(1);
  if (i >= params->stats_w || j >= params->stats_h) return;
  int x = params->stats_x + i, y = params->stats_y + j;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  vec3 range;
  vec3 sum = tr_adaptive_first(&s, x, y, &range);
  tr_adaptive_store_stats(params, stats, x, y, sum, range);
  int rx = x - params->rect_x, ry = y - params->rect_y;
  if (rx >= 0 && ry >= 0 && rx < params->rect_w && ry < params->rect_h)
    tr_store_rgb(out, params->rect_w, rx, ry, sum * (TR_R(1.0) / (real)params->spp));
}

/* Criterion, every pixel of the rectangle: 1 in `flags` where the pixel is refined. */
__kernel void tr_kernel_adaptive_mark(__global const TrParams* params, __global const real* stats,
                                      __global int* flags) {
  int i = (int)get_global_id(0), j = (int)get_global_id(1);
  if (i >= params->rect_w || j >= params->rect_h) return;
  flags[j * params->rect_w + i] =
      tr_adaptive_refine_flag(params, stats, params->rect_x + i, params->rect_y + j);
}

/* Second pass, one work-item per refined pixel (`pixels`: j * rect_w + i inside the
 * rectangle, `count` of them). */
__kernel void tr_kernel_adaptive_refine(TR_SCENE_ARGS, __global real* out,
                                        __global const real* stats, __global const int* pixels,
                                        int count) {
  int k = (int)get_global_id(0);
  if (k >= count) return;
  int i = pixels[k] % params->rect_w, j = pixels[k] / params->rect_w;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  tr_store_rgb(out, params->rect_w, i, j,
               tr_adaptive_refine(&s, stats, params->rect_x + i, params->rect_y + j));
}

#endif

#if TR_HOLDS(TR_ENTRY_QUERY)
/* Ray queries (device/ray_query.h), one work-item per ray: rays [get_global_offset(0),
 * end) of the buffers, the range launched in pieces through the global offset. `extras`
 * is written only where extra_flags asks for some. */
__kernel void tr_kernel_intersect(TR_SCENE_ARGS, __global const TrQueryRay* rays,
                                  __global TrQueryHit* hits, __global TrQueryExtras* extras,
                                  int extra_flags, ulong end) {
  size_t i = get_global_id(0);
  if (i >= end) return;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  tr_query_intersect(&s, &rays[i], &hits[i], &extras[extra_flags != 0 ? i : 0], extra_flags);
}

/* blocked[i] = 1 where anything lies on ray i within its interval, else 0. */
__kernel void tr_kernel_occluded(TR_SCENE_ARGS, __global const TrQueryRay* rays,
                                 __global uchar* blocked, ulong end) {
  size_t i = get_global_id(0);
  if (i >= end) return;
  TrSceneRef s = tr_scene_ref(TR_SCENE_ARG_NAMES);
  blocked[i] = (uchar)(tr_query_occluded(&s, &rays[i]) ? 1 : 0);
}

#endif

#if TR_ENTRY_POINTS == TR_ENTRY_ALL
/* Every sample position of every pixel, for tests of device/sampling.h:
 * out[((y * width + x) * spp + i) * 2 + {0, 1}] = (x, y) of sample i. */
__kernel void tr_kernel_sample_positions(__global real* out, int sampler, int seed, int spp,
                                         int width, int height) {
  int x = (int)get_global_id(0), y = (int)get_global_id(1);
  if (x >= width || y >= height) return;
  for (int i = 0; i < spp; ++i) {
    TrSample2 smp = tr_sample_position_seeded(sampler, seed, i, spp, x, y);
    int k = ((y * width + x) * spp + i) * 2;
    out[k] = smp.x;
    out[k + 1] = smp.y;
  }
}

/* sizeof of every buffer struct as the device compiler lays it out; the host compares
 * them with its own (tests/backend/opencl_program_test.cpp). */
__kernel void tr_kernel_layout_sizes(__global int* out) {
  if (get_global_id(0) != 0) return;
  out[0] = (int)sizeof(TrSphere);
  out[1] = (int)sizeof(TrTriangle);
  out[2] = (int)sizeof(TrPlane);
  out[3] = (int)sizeof(TrMaterial);
  out[4] = (int)sizeof(TrLight);
  out[5] = (int)sizeof(real); /* bvh_nodes' boxes */
  out[6] = (int)sizeof(TrParams);
  out[7] = (int)sizeof(TrTriangleAttr);
  out[8] = (int)sizeof(TrTexture);
  out[9] = (int)sizeof(TrQueryRay);
  out[10] = (int)sizeof(TrQueryHit);
  out[11] = (int)sizeof(TrQueryExtras);
  out[12] = (int)sizeof(TrInstance);
}
#endif
