/* The Features mask: what a scene and its render options use. It is a compile-time
 * constant on both sides (-DTR_FEATURES=... for OpenCL, a template argument on the
 * host), so code guarded by TR_HAS(bit) is dead on both sides when the bit is clear.
 * Bits name structure only; camera pose, projection, light positions and counts,
 * image size and frame number are buffer data, so changing them never rebuilds a
 * program. */
#ifndef TWINRAY_DEVICE_FEATURES_H
#define TWINRAY_DEVICE_FEATURES_H

#define TR_F_SPHERES 0x001u       /* scene has spheres */
#define TR_F_TRIANGLES 0x002u     /* scene has triangles (single or from meshes) */
#define TR_F_PLANES 0x004u        /* scene has infinite planes */
#define TR_F_BVH2 0x008u          /* spheres and triangles are walked through a 2-wide BVH */
#define TR_F_SHADOWS 0x010u       /* shadow rays are traced */
#define TR_F_GLAZE 0x020u         /* reflected rays are traced (something glazed, depth > 1) */
#define TR_F_AMBIENT 0x040u       /* ambient term on */
#define TR_F_DIFFUSE 0x080u       /* diffuse term on */
#define TR_F_SPECULAR 0x100u      /* specular term on */
#define TR_F_ATTRIBUTES 0x200u    /* some triangles carry vertex normals or uvs (TrTriangleAttr) */
#define TR_F_TEXTURES 0x400u      /* some material has a texture */
#define TR_F_BVH4 0x800u          /* ... through a 4-wide BVH */
#define TR_F_BVH8 0x1000u         /* ... through an 8-wide BVH */
#define TR_F_MASKS 0x2000u        /* some object has a mask other than all ones (ray queries) */
#define TR_F_DIELECTRIC 0x4000u   /* some material transmits (glass: trace.h, dielectric.h) */
#define TR_F_AREA_LIGHTS 0x8000u  /* some light is a rect or a sphere (area_light.h) */
#define TR_F_ENVIRONMENT 0x10000u /* rays that miss see an environment image (environment.h) */
#define TR_F_INSTANCES 0x20000u   /* assets placed by instances: a two-level BVH (instance.h) */
#define TR_F_ALL 0x3ffffu         /* the generic program: every feature compiled in */
/* A BVH of any width. A packed scene with a BVH sets exactly one of the three bits: the
 * width its nodes were built for (pack/bvh.hpp). */
#define TR_F_BVH (TR_F_BVH2 | TR_F_BVH4 | TR_F_BVH8)
/* Host-only: benchmarks instantiate the CPU code with this bit to count every ray
 * query (TR_COUNT_RAY in prelude.h). Never set by a render, never on the device. */
#define TR_F_COUNT_RAYS 0x80000000u

/* Which kernels an OpenCL program holds (-DTR_ENTRY_POINTS, kernels/render.cl): all,
 * or only what one kind of render launches. PoCL compiles work-group code for every
 * kernel of a program when its binary is read for the disk cache, so a program that
 * holds one render's kernels is ready sooner (docs/performance.md, "PoCL program
 * build, cold and cached"). */
#define TR_ENTRY_ALL 0
#define TR_ENTRY_RENDER 1   /* tr_kernel_render: a pixel per work-item */
#define TR_ENTRY_AOV 2      /* tr_kernel_aov */
#define TR_ENTRY_ADAPTIVE 3 /* tr_kernel_adaptive_first, _mark and _refine */
#define TR_ENTRY_BLOCKS 4   /* tr_kernel_render_blocks: an 8x8 block per work-item */
#define TR_ENTRY_QUERY 5    /* tr_kernel_intersect and tr_kernel_occluded (ray_query.h) */

#endif /* TWINRAY_DEVICE_FEATURES_H */
