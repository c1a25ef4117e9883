/* Every struct the device code uses, defined once for both sides.
 *
 * Buffer structs (everything the host packs and uploads) hold plain `real` and `int`
 * fields only, never vec3: float3 is 16 bytes in OpenCL and glm::vec3 is 12. Reals come
 * first and ints pad to an even count, so sizeof and every offset agree between g++ and
 * OpenCL in float and double; device/code.hpp checks the sizes with static_assert
 * and the tests check them against the kernel's own sizeof.
 *
 * No include guard: the host includes this file once per precision, in namespaces
 * twinray::device::f32 and ::f64, and under clang the working structs once more per
 * precision, in ::f32_vec and ::f64_vec (code.hpp). */

/* ---- buffer structs ---- */
#ifndef TR_WORKING_TYPES_ONLY /* code.hpp's native-vector instantiations share these */

typedef struct TrSphere {
  real cx, cy, cz, radius;
  int material, object, pad0, pad1;
} TrSphere;

/* Vertices inline: a mesh's shared vertices become bit-identical copies, which is all
 * the watertight test needs (both triangles see the same edge). */
typedef struct TrTriangle {
  real p0x, p0y, p0z, p1x, p1y, p1z, p2x, p2y, p2z;
  int material, object;
} TrTriangle;

/* Unit normal; the host normalizes it when packing. */
typedef struct TrPlane {
  real px, py, pz, nx, ny, nz;
  int material, object;
} TrPlane;

/* Shading attributes of one triangle, in the triangles' packed order (present only when
 * some mesh has normals or uvs, TR_F_ATTRIBUTES): unit vertex normals and texture
 * coordinates of its three corners, each used where its flag bit is set. Kept apart
 * from TrTriangle so that traversal, which reads only positions, stays as lean. */
#define TR_ATTR_NORMALS 1
#define TR_ATTR_UV 2
typedef struct TrTriangleAttr {
  real n0x, n0y, n0z, n1x, n1y, n1z, n2x, n2y, n2z;
  real u0, v0, u1, v1, u2, v2;
  int flags, pad0;
} TrTriangleAttr;

/* texture: index into the texture array, or -1 (device/texture.h). transmission, ior
 * and the absorption coefficients (per unit length, per channel) make a dielectric
 * (dielectric.h); transmission 0 is opaque. */
typedef struct TrMaterial {
  real r, g, b, ka, kd, ks, shininess, glaze;
  real transmission, ior, absorb_r, absorb_g, absorb_b;
  int texture, pad0;
} TrMaterial;

/* An RGB texture: width x height texels of 3 linear reals from texels[first], row 0
 * at the top (v = 1). */
typedef struct TrTexture {
  int width, height, first, pad0;
} TrTexture;

/* A light (scene/light.hpp): a point, or an area light that shading sees as n x n point
 * lights spread over it (area_light.h). p: the point light's position, the rect's
 * corner or the sphere's center; r, g, b: the radiant intensity per channel of each of
 * its shadow samples, color x intensity / n^2, premultiplied by the host; e1, e2: the
 * rect's edges; radius: the sphere's. */
#define TR_LIGHT_POINT 0
#define TR_LIGHT_RECT 1
#define TR_LIGHT_SPHERE 2
typedef struct TrLight {
  real px, py, pz, r, g, b;
  real e1x, e1y, e1z, e2x, e2y, e2z, radius;
  int shape;   /* TR_LIGHT_POINT, _RECT or _SPHERE */
  int samples; /* n: n x n shadow samples (1 for a point light) */
  int pad0;
} TrLight;

/* One placement of an asset (scene/instance.hpp, device/instance.h): the affine maps
 * from world to the asset's space and back, each 3 rows of (x, y, z, translation),
 * computed once on the host in double and rounded to real. The asset's primitives lie
 * in the packed arrays like any others, in its own space, under its own BVH (root node
 * `root`); the top-level BVH's leaves list instances (bvh_traverse.h). */
typedef struct TrInstance {
  real to_object[12];
  real to_world[12];
  int root;          /* the asset's BVH root node */
  int object;        /* the instance's index in the scene's objects: its key in the hit
                        order and its object AOV value */
  int material;      /* replaces the asset's materials; -1: keeps them */
  unsigned int mask; /* ray queries skip the instance where it shares no bit with the ray's */
} TrInstance;

/* The BVH, W children per node (W = 2, 4 or 8: the TR_F_BVH2/4/8 bit of the scene), in
 * one buffer, bvh_nodes, node after node (bvh_traverse.h tr_bvh_node). No struct: its
 * size would depend on W. A node holds
 *  - 6 W reals: the children's boxes as structure of arrays, plane by plane (min x of
 *    the W children, then min y, min z, max x, max y, max z), so the walk tests all W
 *    boxes with one loop over contiguous values (bvh_traverse.h);
 *  - then 2 W ints: first[W], then count[W]. Child k is a leaf when count[k] > 0
 *    (primitives bvh_prims[first[k] .. first[k] + count[k])), an inner node when
 *    count[k] == 0 (node first[k]) and an empty slot when count[k] < 0; an empty
 *    slot's box is empty (min +inf, max -inf), so no ray enters it.
 * A node's links follow its boxes in memory: a walk that tests the boxes finds the links
 * in the cache lines it has just read, where two arrays cost a second miss per node
 * (3-4% of a frame of 1e6 triangles or spheres, docs/performance.md). 6 W reals keep
 * the ints aligned, and 2 W ints fill W or 2 W whole reals, so every node starts
 * aligned for both. The buffer is only ever read, each value through its own type.
 * Node 0 is the root. */
#define TR_BVH_MIN_X 0
#define TR_BVH_MAX_X 3
#define TR_BVH_MAX_WIDTH 8

/* The rows of a wide node's boxes that the slab test reads for a direction:
 * per axis the plane a ray meets first (the max plane where d < 0) and the one it
 * leaves by (bvh_traverse.h tr_slab_rows). */
typedef struct TrSlabRows {
  int near_x, near_y, near_z, far_x, far_y, far_z;
} TrSlabRows;

/* Those rows of one node, as pointers to its W values each (tr_box_planes). */
typedef struct TrBoxPlanes {
  TR_GLOBAL const real *near_x, *near_y, *near_z, *far_x, *far_y, *far_z;
} TrBoxPlanes;

/* Per-frame data: camera, image, counts and run-time switches. */
typedef struct TrParams {
  real origin_x, origin_y, origin_z;                /* camera position */
  real first_pixel_x, first_pixel_y, first_pixel_z; /* center of pixel (0, 0) */
  real du_x, du_y, du_z;                            /* one pixel to the right */
  real dv_x, dv_y, dv_z;                            /* one pixel down */
  real ortho_dir_x, ortho_dir_y, ortho_dir_z;       /* -W, the orthographic ray direction */
  real bg_r, bg_g, bg_b;                            /* background color */
  real adaptive_threshold; /* refine a pixel whose contrast exceeds it (device/adaptive.h) */
  /* The environment image (environment.h): its frame (unit right, up and forward
   * vectors: +x, +y and -z by default), turns of the map about its up (rotate_degrees /
   * 360) and the factor on its texels. */
  real env_right_x, env_right_y, env_right_z, env_up_x, env_up_y, env_up_z;
  real env_forward_x, env_forward_y, env_forward_z;
  real env_turns, env_intensity;
  int width, height; /* the whole frame */
  /* The pixels this render computes: the framebuffer holds rect_w x rect_h of them,
   * from (rect_x, rect_y). Adaptive sampling's first pass covers the statistics window,
   * the rectangle plus a one-pixel border clipped to the frame (pack/pack.hpp). */
  int rect_x, rect_y, rect_w, rect_h;
  int stats_x, stats_y, stats_w, stats_h;
  int projection; /* 0 perspective, 1 orthographic */
  int spp, sampler, max_depth;
  int seed;         /* sampler seed: jitter and per-pixel shifts (device/sampling.h) */
  int adaptive_spp; /* samples of a refined pixel; 0: adaptive sampling off */
  int n_spheres, n_triangles, n_planes, n_lights, n_bvh_nodes;
  int features;    /* the run-time Features mask: switches inside the compiled ones */
  int environment; /* the environment's texture index; -1: none (the background color) */
  /* The BVH's roots (bvh_traverse.h): the scene's own spheres and triangles, and the
   * top level over its instances (TR_F_INSTANCES); -1 where there is none. */
  int scene_root, instance_root, n_instances;
} TrParams;

/* A ray of a user's query (ray_query.h; twinray::Ray<T> on the host): origin o,
 * direction d (any nonzero length; t counts lengths of d), the interval [tmin, tmax]
 * hits are looked for in, and a 32-bit mask: objects whose mask shares no bit with it
 * are skipped. */
typedef struct TrQueryRay {
  real ox, oy, oz, dx, dy, dz, tmin, tmax;
  unsigned int mask, pad0;
} TrQueryRay;

/* The closest hit of a query ray (twinray::Hit<T>): distance t along the ray, surface
 * parameters u, v (barycentrics of vertices 1 and 2 on a triangle; ray_query.h says
 * what they are on spheres and planes), the unit geometric normal turned toward the
 * ray's origin; the object's index in the scene and the triangle's index in its mesh
 * (0 for other shapes). A miss: t = +inf, object = primitive = -1, the rest 0. */
typedef struct TrQueryHit {
  real t, u, v, nx, ny, nz;
  int object, primitive;
  int instance; /* the instance's index in the scene's objects, with `object` the object's
                   index in its asset (as Embree's instID and geomID); -1 outside instances */
  int pad0;
} TrQueryHit;

/* What a query adds to a hit on request (twinray::HitExtras): the unit shading normal
 * (the geometric one where the triangle has no vertex normals), turned to the side of
 * the geometric normal, and the texture coordinates (0 where there are none). */
#define TR_QUERY_SHADING_NORMAL 1
#define TR_QUERY_TEXTURE_UV 2
typedef struct TrQueryExtras {
  real snx, sny, snz, tex_u, tex_v, pad0;
} TrQueryExtras;

/* ---- private (never uploaded) ---- */

/* Pointers into the scene buffers: one argument instead of nine. */
typedef struct TrSceneRef {
  TR_GLOBAL const TrParams* params;
  TR_GLOBAL const TrSphere* spheres;
  TR_GLOBAL const TrTriangle* triangles;
  TR_GLOBAL const TrPlane* planes;
  TR_GLOBAL const TrMaterial* materials;
  TR_GLOBAL const TrLight* lights;
  TR_GLOBAL const real* bvh_nodes;
  TR_GLOBAL const int* bvh_prims;
  TR_GLOBAL const TrTriangleAttr* triangle_attrs;
  TR_GLOBAL const TrTexture* textures;
  TR_GLOBAL const real* texels;
  /* Ray queries only: each object's mask, by object index (read only with TR_F_MASKS),
   * and each triangle's index in its mesh, in the triangles' packed order. */
  TR_GLOBAL const unsigned int* object_masks;
  TR_GLOBAL const int* triangle_faces;
  TR_GLOBAL const TrInstance* instances; /* in the top-level BVH's leaf order */
} TrSceneRef;
#endif /* TR_WORKING_TYPES_ONLY */

/* ---- working structs: the only ones that hold vec3 ---- */

/* A ray as the box test wants it: 1/d, 1/d padded for the far planes (bvh_traverse.h),
 * and the rows of the boxes it reads. */
typedef struct TrBoxRay {
  vec3 o, inv_d, inv_d_far;
  TrSlabRows rows;
} TrBoxRay;

typedef struct TrRay {
  vec3 o, d; /* d has unit length */
} TrRay;

/* The ray's part of the watertight triangle test (intersect_triangle.h): the axis
 * permutation and the shear. */
typedef struct TrTriangleRay {
  real sx, sy, sz;
  int kx, ky, kz;
} TrTriangleRay;

typedef struct TrHit {
  real t;
  vec3 p;    /* hit point, refined onto the surface */
  vec3 perr; /* per-axis bound on the error of p (pbrt-v4's pError) */
  vec3 n;    /* unit geometric normal, not yet turned toward the ray */
  vec3 ns;   /* unit shading normal (interpolated vertex normal, else n), not turned */
  /* Where shadow rays start, and the bound on its error: p, except on a triangle with
   * vertex normals (the shadow terminator, intersect_triangle.h). */
  vec3 shadow_p, shadow_perr;
  real u, v; /* texture coordinates; 0 where the primitive has none */
  int material, object;
} TrHit;

/* The nearest hit found so far: only its distance and primitive (ids: spheres, then
 * triangles, then planes, each in packed order; -1 while there is none, with t the
 * ray's tmax). The hit record is made from it once, at the end (scene_hit.h). A ray
 * query's walk also keeps the nearest triangle hit's barycentrics, so that its answer
 * needs no second test (tr_bvh_walk_query), in a real[2] beside this struct, not in
 * it: the renderer passes it by value, 12 bytes in two registers (with the two more
 * it went through memory, and frames of mesh_1e6 took 1.12 times as long). */
typedef struct TrNearest {
  real t;
  int prim;
  int instance; /* where the hit is in an asset: the instance (index into instances), else -1 */
} TrNearest;

/* A packet of rays walked together (bvh_packet.h): the rays, their box-test and
 * triangle-test views one array per component (so per-ray work runs a ray per SIMD
 * lane), each ray's nearest hit, and, for a coherent packet, the bounds of origins
 * and reciprocal directions over all rays and the slab planes they share. */
#define TR_PACKET_MAX 64
#define TR_BLOCK_SIDE 8  /* tr_render_block's blocks, TR_BLOCK_SIDE^2 <= TR_PACKET_MAX rays */
#define TR_TILE_BLOCKS 4 /* tr_tiled_block: tiles of TR_TILE_BLOCKS^2 blocks */
typedef struct TR_ALIGNED(TR_LINE_BYTES) TrRayPacket {
  /* The ray count first, alone on its cache line: placed after the arrays, where a
   * store to an element could reach it as far as a compiler can tell, it made PoCL's
   * demo frames 1.07-1.16 times as long (docs/performance.md). */
  int n;
  int n_line[TR_LINE_BYTES / sizeof(int) - 1]; /* unused: the arrays start on the next line */
  /* The per-ray arrays: each is TR_PACKET_MAX 4- or 8-byte values, a whole number of
   * cache lines, so with the struct aligned to a line each 16-ray group of a lane loop
   * starts on one. Off the lines, every group straddled two (and every 256-bit load
   * two 32-byte halves), an extra load per vector. */
  real tri_sx[TR_PACKET_MAX], tri_sy[TR_PACKET_MAX], tri_sz[TR_PACKET_MAX]; /* TrTriangleRay */
  int tri_kx[TR_PACKET_MAX], tri_ky[TR_PACKET_MAX], tri_kz[TR_PACKET_MAX];
  real ox[TR_PACKET_MAX], oy[TR_PACKET_MAX], oz[TR_PACKET_MAX];
  real dx[TR_PACKET_MAX], dy[TR_PACKET_MAX], dz[TR_PACKET_MAX];
  real ix[TR_PACKET_MAX], iy[TR_PACKET_MAX], iz[TR_PACKET_MAX];
  real fx[TR_PACKET_MAX], fy[TR_PACKET_MAX], fz[TR_PACKET_MAX];
  real t[TR_PACKET_MAX];
  int prim[TR_PACKET_MAX];
  TrRay ray[TR_PACKET_MAX];
  vec3 o_lo, o_hi, i_lo, i_hi, f_lo, f_hi;
  TrSlabRows rows; /* shared: every ray's direction has the same signs */
  /* Ray queries: each ray's nearest triangle hit's barycentrics (tr_bvh_walk_query's
   * uv). Last, so that the renderer's fields keep their places. */
  TR_ALIGNED(TR_LINE_BYTES) real u[TR_PACKET_MAX];
  real v[TR_PACKET_MAX];
} TrRayPacket;

/* What a packet of ray queries adds to the renderer's packet (ray_query.h): each ray's
 * tmin and mask, one array each (read a ray per SIMD lane by the leaves' tests), and
 * the index of each ray in the caller's run of rays. */
typedef struct TR_ALIGNED(TR_LINE_BYTES) TrQueryLanes {
  real tmin[TR_PACKET_MAX];
  unsigned int mask[TR_PACKET_MAX];
} TrQueryLanes;
#define TR_QUERY_RUN 256 /* rays grouped by octant at a time (ray_query.h) */
typedef struct TrQueryPacket {
  TrRayPacket packet;
  TrQueryLanes lanes;
  int index[TR_PACKET_MAX];
  /* The run's rays in packet order: each ray's octant (-1: alone), the order, and where
   * each group of rays starts in it (tr_query_group_run). */
  int octant[TR_QUERY_RUN], order[TR_QUERY_RUN], group_start[9];
} TrQueryPacket;

/* A point light, or one sample of an area light, as shading sees it from a hit (shading.h): where
 * it is, the irradiance it brings, the unit direction l to it and n.l; which terms it adds. */
#define TR_LIGHT_NONE 0    /* the hit is at the light: no term */
#define TR_LIGHT_AMBIENT 1 /* ambient only: behind the surface, or no other term on */
#define TR_LIGHT_ALL 2     /* every term, unless its shadow ray is blocked */
typedef struct TrLightView {
  vec3 pos, irradiance, l;
  real n_dot_l;
  int lit;
} TrLightView;

/* What shading reads of a hit before its lights (shading.h): the albedo and the
 * shading normal turned to face the incoming ray. */
typedef struct TrSurface {
  vec3 albedo, n;
} TrSurface;

/* A camera ray's path through its mirror chain (trace.h): the ray of its next segment,
 * the color so far, the product of the glaze (and, through glass, Fresnel and
 * absorption) factors passed, and how many segments it may still take (0: done). */
typedef struct TrPath {
  TrRay ray;
  vec3 from; /* the surface point the ray left (its origin before the offset): glass
              * absorbs over the distance from it to the point where the ray leaves */
  vec3 color;
  vec3 weight;
  int segments_left;
} TrPath;

/* The rays a path has still to trace where glass split it in two (trace.h): each with
 * its weight and the segments left to it, last in first out. A tree deeper than
 * TR_RAY_STACK pending rays drops the reflected ray of the split that finds it full. */
#define TR_RAY_STACK 8
typedef struct TrPendingRay {
  TrRay ray;
  vec3 from, weight;
  int segments_left;
} TrPendingRay;
typedef struct TrRayStack {
  int n;
  TrPendingRay ray[TR_RAY_STACK];
} TrRayStack;

/* A vec3 for each of a packet's rays or hits, one array per component, so that a loop
 * over them runs one per SIMD lane (tr_lane3, tr_set_lane3: math.h). */
typedef struct TrVec3Lanes {
  real x[TR_PACKET_MAX], y[TR_PACKET_MAX], z[TR_PACKET_MAX];
} TrVec3Lanes;

/* Working memory of tr_render_block (trace.h): a block's paths; one segment's hits,
 * their surfaces and shaded colors so far; one light as each hit sees it, and which
 * hits' shadow rays toward it went into the packet (lane) and are blocked. */
typedef struct TrBlockScratch {
  TrRayPacket packet;
  /* One light's specular terms over the hits: which hits have one, the base n.h of
   * each and its power (tr_specular_powers, whose loops run a hit per SIMD lane: line
   * aligned, as the packet's arrays are). */
  TR_ALIGNED(TR_LINE_BYTES) int specular[TR_PACKET_MAX];
  real n_dot_h[TR_PACKET_MAX], power[TR_PACKET_MAX];
  TrPath path[TR_PACKET_MAX];
  /* The word each path's area light samples come from (tr_path_seed: area_light.h); set
   * only where area lights are compiled in. Apart from TrPath, which stays 64 bytes. */
  unsigned int path_seed[TR_PACKET_MAX];
  TrHit hit[TR_PACKET_MAX];
  TrSurface surface[TR_PACKET_MAX];
  vec3 shaded[TR_PACKET_MAX];
  /* The segment's hits in ray order, the q-th from ray found_ray[q]: what the light
   * loop reads of each, one array per component and set once a segment (the hit point,
   * the shadow origin and its error bound, the geometric and the facing normal); one
   * light sample as each sees it (TrLightView's fields; the sample's position, which on
   * an area light differs from hit to hit, in light_pos); whether its
   * shadow ray toward that light is traced (the ray is made in the packet's ox .. dz
   * and t at index q) and blocked (blocked[q]). The loop that makes them runs a hit
   * per SIMD lane over contiguous loads: from the hit records, each component was a
   * gather, and a lane per ray, hit or not, did the misses' work too. */
  TR_ALIGNED(TR_LINE_BYTES) TrVec3Lanes hit_p;
  TrVec3Lanes hit_shadow_p, hit_shadow_perr, hit_n, hit_facing_n;
  TrVec3Lanes light_pos, light_irradiance, light_l;
  real light_n_dot_l[TR_PACKET_MAX];
  int light_lit[TR_PACKET_MAX], shadow_traced[TR_PACKET_MAX], found_ray[TR_PACKET_MAX];
  int found[TR_PACKET_MAX], slot[TR_PACKET_MAX], lane[TR_PACKET_MAX];
  int lane_blocked[TR_PACKET_MAX], blocked[TR_PACKET_MAX];
  /* The share of a light that reaches each hit through glass (1 or 0 where nothing
   * transmits: shading.h tr_shadow_transmittance). */
  real through[TR_PACKET_MAX];
} TrBlockScratch;

typedef struct TrSample2 {
  real x, y; /* position inside the pixel, in [0, 1) */
} TrSample2;
