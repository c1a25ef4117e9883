/* Iterative traversal of the W-wide BVH (types.h: bvh_nodes) with a small
 * fixed stack (no recursion: OpenCL C has none). The one walk serves W = 2, 4 and 8: W
 * is an argument that every caller passes as a constant to an always-inlined body, so
 * each width is compiled with a fixed trip count for its box loop, which g++
 * vectorizes and PoCL compiles from the same text. Box test: the slab method with the
 * far distances scaled by 1 + 2 gamma(3), so rounding never culls a box the ray
 * touches (pbrt-v4 Bounds3::IntersectP, folded into the reciprocal as Ize 2013). */

/* Leaf depth cap of the binary tree the wide one is collapsed from (pack/bvh.hpp), and
 * the traversal stack. A walk holds at most (inner children - 1) entries per wide node
 * on its path; the collapse checks each tree against this size and, where the greedy
 * tree would need more, collapses at fixed levels: a W-wide node (W = 2^L) then stands
 * for L binary levels, so a path holds at most floor((48 - 1) / L) + 1 inner wide
 * nodes of W - 1 entries each: 48 entries at W = 2, 72 at 4, 112 at 8. */
#define TR_BVH_MAX_DEPTH 48
#define TR_BVH_STACK_SIZE 112
/* A walk through instances holds the top level's path, at most one top-level node's
 * instances (W leaves of at most 8: pack/bvh_constants.hpp, kMaxLeafSize) over the child
 * it had picked, a mark, and an asset's path. The stack is that large only where instances are
 * compiled in. */
#define TR_WALK_STACK_SIZE \
  (TR_HAS(TR_F_INSTANCES) ? 2 * TR_BVH_STACK_SIZE + 8 * TR_BVH_MAX_WIDTH + 2 : TR_BVH_STACK_SIZE)
/* Stack marks of the instance walk: leave the asset (back to the world's ray), and
 * enter instance i. */
#define TR_WALK_LEAVE (-2)
#define TR_WALK_ENTER(i) (-3 - (i))

/* The reals one node of the W-wide tree takes (types.h, "The BVH"): its boxes, 6 W
 * reals, then its links, 2 W ints (the room of 2 W reals in float, W in double). */
TR_FN_INLINE int tr_bvh_node_reals(int W) {
  return 6 * W + 2 * W * (int)sizeof(int) / (int)sizeof(real);
}
/* Node `index` of the W-wide tree. */
TR_FN_INLINE TR_GLOBAL const real* tr_bvh_node(const TrSceneRef* s, int index, int W) {
  return s->bvh_nodes + index * tr_bvh_node_reals(W);
}
/* The node's links: first[W], then count[W]. */
TR_FN_INLINE TR_GLOBAL const int* tr_bvh_node_links(TR_GLOBAL const real* node, int W) {
  return (TR_GLOBAL const int*)(node + 6 * W);
}

/* Asks for the cache lines of bytes [p, p + bytes) (TR_PREFETCH). */
TR_FN_INLINE void tr_prefetch_bytes(TR_GLOBAL const void* p, int bytes) {
  TR_GLOBAL const char* c = (TR_GLOBAL const char*)p;
  for (int offset = 0; offset < bytes; offset += TR_LINE_BYTES) TR_PREFETCH(c + offset);
  TR_PREFETCH(c + bytes - 1); /* the last line, where p is not at a line's start */
}

/* The primitive id at position i of the leaves' order, bvh_prims[i]. The packed arrays
 * are in that order (pack/pack.hpp), so where the scene holds spheres only or
 * triangles only the id is i itself, and the walks skip the read: a load that every
 * leaf's primitive tests waited on, from an array that does not fit in cache on large
 * scenes. tr_bvh_prims_indirect: whether the read is needed (spheres and triangles). */
TR_FN_INLINE int tr_bvh_prims_indirect(const TrSceneRef* s) {
  return TR_HAS(TR_F_SPHERES) && TR_HAS(TR_F_TRIANGLES) && s->params->n_spheres > 0 &&
         s->params->n_triangles > 0;
}
TR_FN_INLINE int tr_bvh_prim(const TrSceneRef* s, int i) {
  return tr_bvh_prims_indirect(s) ? s->bvh_prims[i] : i;
}

/* Asks for what the walk reads next from the children a ray enters (bits of `mask`,
 * links first[] and count[]): an inner child's node, a leaf's primitives (or a top
 * level's instances). Asked all at once, before any is read, their cache misses
 * overlap where the walk would otherwise wait on one after another: a profile of the
 * forest's frames put 40% of the walk's time on the first load of a node and of a leaf. */
TR_FN_INLINE void tr_prefetch_children(const TrSceneRef* s, unsigned mask,
                                       TR_GLOBAL const int* first, TR_GLOBAL const int* count,
                                       int W, int instances) {
  int node_bytes = tr_bvh_node_reals(W) * (int)sizeof(real);
  int mixed = tr_bvh_prims_indirect(s);
  for (; mask != 0u; mask &= mask - 1u) {
    int k = TR_LOWEST_BIT(mask), n = count[k];
    if (n == 0) {
      tr_prefetch_bytes(tr_bvh_node(s, first[k], W), node_bytes);
    } else if (n > 0) {
      if (instances)
        tr_prefetch_bytes(&s->instances[first[k]], n * (int)sizeof(TrInstance));
      else if (mixed)
        tr_prefetch_bytes(&s->bvh_prims[first[k]], n * (int)sizeof(int));
      else if (TR_HAS(TR_F_SPHERES) && s->params->n_spheres > 0)
        tr_prefetch_bytes(&s->spheres[first[k]], n * (int)sizeof(TrSphere));
      else if (TR_HAS(TR_F_TRIANGLES))
        tr_prefetch_bytes(&s->triangles[first[k]], n * (int)sizeof(TrTriangle));
    }
  }
}

/* BVH primitive ids: spheres first, then triangles. Only the distance: see TrNearest. */
TR_FN_INLINE real tr_primitive_t(const TrSceneRef* s, int prim, TrRay ray,
                                 const TrTriangleRay* tri_ray) {
  int n_spheres = s->params->n_spheres;
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres) return tr_sphere_t(&s->spheres[prim], ray);
  if (TR_HAS(TR_F_TRIANGLES)) return tr_triangle_t(&s->triangles[prim - n_spheres], ray, tri_ray);
  return TR_R(0.0);
}

/* The same for a ray query: a sphere's first crossing from tmin on; a triangle's
 * barycentrics in *bary where it is hit (left as they are elsewhere). */
TR_FN_INLINE real tr_primitive_t_from(const TrSceneRef* s, int prim, TrRay ray,
                                      const TrTriangleRay* tri_ray, real tmin, vec3* bary) {
  int n_spheres = s->params->n_spheres;
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres)
    return tr_sphere_t_from(&s->spheres[prim], ray, tmin);
  if (TR_HAS(TR_F_TRIANGLES))
    return tr_triangle_t_bary(&s->triangles[prim - n_spheres], ray, tri_ray, bary);
  return TR_R(0.0);
}

/* A nearest hit to start a walk from, or to carry one over: distance t (the ray's tmax
 * while prim is -1), outside instances. */
TR_FN_INLINE TrNearest tr_nearest(real t, int prim) {
  TrNearest n;
  n.t = t;
  n.prim = prim;
  n.instance = -1;
  return n;
}

/* Keeps (t, prim) if it comes before the nearest hit so far in the order of t, then
 * primitive id. The order is total, so the nearest hit does not depend on the order
 * primitives are tested in: neither the BVH's shape and width nor the order children
 * are visited can change a pixel, on any backend. (Ties are real: a ray through an
 * edge two triangles share hits both at the same t.) */
TR_FN_INLINE int tr_hit_precedes(real t, int prim, real nearest_t, int nearest_prim) {
  return (t > TR_R(0.0)) & ((t < nearest_t) | ((t == nearest_t) & (prim < nearest_prim)));
}
TR_FN_INLINE void tr_offer_hit(TrNearest* nearest, real t, int prim) {
  if (tr_hit_precedes(t, prim, nearest->t, nearest->prim)) {
    nearest->t = t;
    nearest->prim = prim;
  }
}

/* With instances (TR_F_INSTANCES) the order is that of (t, instance, primitive), the
 * instance by its index in the scene's objects and -1 for the scene's own primitives
 * (which come first): still total, so no instance order or traversal changes a pixel.
 * inst: the hit's instance (index into instances), -1 for none. */
TR_FN_INLINE int tr_instance_key(const TrSceneRef* s, int inst) {
  return inst < 0 ? -1 : s->instances[inst].object;
}
TR_FN_INLINE void tr_offer_hit_in(const TrSceneRef* s, TrNearest* nearest, real t, int prim,
                                  int inst) {
  if (!TR_HAS(TR_F_INSTANCES)) {
    tr_offer_hit(nearest, t, prim);
    return;
  }
  if (!(t > TR_R(0.0)) || t > nearest->t) return;
  if (t == nearest->t) {
    int key = tr_instance_key(s, inst), nearest_key = tr_instance_key(s, nearest->instance);
    if (key > nearest_key || (key == nearest_key && prim >= nearest->prim)) return;
  }
  nearest->t = t;
  nearest->prim = prim;
  nearest->instance = inst;
}

/* Ray queries (ray_query.h) order hits by (t, object, primitive in its object), the
 * scene's own numbering, which no packing or BVH changes: this is a primitive's key
 * after t. Ids as in TrNearest. */
TR_FN_INLINE int tr_query_object(const TrSceneRef* s, int prim) {
  int n_spheres = s->params->n_spheres, n_bounded = n_spheres + s->params->n_triangles;
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres) return s->spheres[prim].object;
  if (TR_HAS(TR_F_TRIANGLES) && prim < n_bounded) return s->triangles[prim - n_spheres].object;
  if (TR_HAS(TR_F_PLANES)) return s->planes[prim - n_bounded].object;
  return -1;
}
TR_FN_INLINE int tr_query_face(const TrSceneRef* s, int prim) {
  int n_spheres = s->params->n_spheres;
  if (TR_HAS(TR_F_TRIANGLES) && prim >= n_spheres && prim < n_spheres + s->params->n_triangles)
    return s->triangle_faces[prim - n_spheres];
  return 0;
}

/* Whether a query keeps (t, prim) over its nearest hit so far: t in [tmin, nearest_t]
 * and > 0, and before it in the order of t, then object, then primitive. While there
 * is none (nearest_prim < 0, nearest_t the ray's tmax) a hit at exactly tmax is kept:
 * the interval is closed. The keys are read on exact ties of t only. */
TR_FN_INLINE int tr_query_precedes_in(const TrSceneRef* s, real t, int inst, int prim, real tmin,
                                      real nearest_t, int nearest_inst, int nearest_prim) {
  if (!(t > TR_R(0.0)) || !(t >= tmin) || !(t <= nearest_t)) return 0;
  if (t < nearest_t || nearest_prim < 0) return 1;
  if (TR_HAS(TR_F_INSTANCES) && inst != nearest_inst)
    return tr_instance_key(s, inst) < tr_instance_key(s, nearest_inst);
  int object = tr_query_object(s, prim), nearest_object = tr_query_object(s, nearest_prim);
  return object < nearest_object ||
         (object == nearest_object && tr_query_face(s, prim) < tr_query_face(s, nearest_prim));
}
/* The same for two hits outside instances. */
TR_FN_INLINE int tr_query_precedes(const TrSceneRef* s, real t, int prim, real tmin, real nearest_t,
                                   int nearest_prim) {
  return tr_query_precedes_in(s, t, -1, prim, tmin, nearest_t, -1, nearest_prim);
}

/* Whether a query ray with mask ray_mask skips primitive prim: its object's mask
 * shares no bit with the ray's (as Embree's RTC_FEATURE_RAY_MASK). Only where the
 * scene has masks (TR_F_MASKS). */
TR_FN_INLINE int tr_query_skips(const TrSceneRef* s, int prim, unsigned int ray_mask) {
  if (!tr_use(s, TR_F_MASKS)) return 0;
  return (s->object_masks[tr_query_object(s, prim)] & ray_mask) == 0u;
}

/* 1 + 2 gamma(3): the factor the box test grows far distances and tmax by, so rounding
 * never culls a box the ray touches (pbrt-v4 Bounds3::IntersectP). */
TR_FN_INLINE real tr_box_grow(void) {
  return TR_R(1.0) + TR_R(2.0) * tr_gamma(3);
}

/* The rows of the boxes the slab test reads for reciprocal direction inv_d: per axis
 * the max plane first where the direction is negative, else the min plane. */
TR_FN_INLINE TrSlabRows tr_slab_rows(vec3 inv_d) {
  TrSlabRows rows;
  rows.near_x = inv_d.x < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X;
  rows.near_y = (inv_d.y < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X) + 1;
  rows.near_z = (inv_d.z < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X) + 2;
  rows.far_x = inv_d.x < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X;
  rows.far_y = (inv_d.y < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X) + 1;
  rows.far_z = (inv_d.z < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X) + 2;
  return rows;
}

/* Those rows of the node whose boxes start at `boxes`, W values each. Shared by the ray's
 * box test and the packet's two (bvh_packet.h). */
TR_FN_INLINE TrBoxPlanes tr_box_planes(TR_GLOBAL const real* boxes, TrSlabRows rows, int W) {
  TrBoxPlanes p;
  p.near_x = boxes + rows.near_x * W;
  p.near_y = boxes + rows.near_y * W;
  p.near_z = boxes + rows.near_z * W;
  p.far_x = boxes + rows.far_x * W;
  p.far_y = boxes + rows.far_y * W;
  p.far_z = boxes + rows.far_z * W;
  return p;
}

/* One component of the box test's reciprocal direction, and that reciprocal padded for
 * the far planes. As scalars, for tr_box_ray and for a packet's rays side by side
 * (tr_packet_begin), whose loop then vectorizes on PoCL as well as in g++. */
TR_FN_INLINE real tr_box_inv(real d) {
  return TR_R(1.0) / d;
}
TR_FN_INLINE real tr_box_inv_far(real inv) {
  return inv * tr_box_grow();
}

/* The box test's view of a ray; computed once per query. */
TR_FN_INLINE TrBoxRay tr_box_ray(TrRay ray) {
  TrBoxRay br;
  br.o = ray.o;
  br.inv_d = TR_VEC3(tr_box_inv(ray.d.x), tr_box_inv(ray.d.y), tr_box_inv(ray.d.z));
  br.inv_d_far =
      TR_VEC3(tr_box_inv_far(br.inv_d.x), tr_box_inv_far(br.inv_d.y), tr_box_inv_far(br.inv_d.z));
  br.rows = tr_slab_rows(br.inv_d);
  return br;
}

/* The end of a slab test, from a box's six slab distances (near planes nx, ny, nz, far
 * planes fx, fy, fz): *t_entry is where the ray enters the box (0 if it starts inside)
 * and *t_exit where it leaves it (at most tmax); tr_slab_enters: whether it enters
 * before tmax, *t_entry <= *t_exit. A NaN distance fails its compare and narrows
 * nothing. Every box test (tr_ray_hits_boxes, and a packet's in bvh_packet.h) ends
 * here. */
TR_FN_INLINE void tr_slab_interval(real nx, real ny, real nz, real fx, real fy, real fz, real tmax,
                                   real* t_entry, real* t_exit) {
  real t0 = TR_R(0.0), t1 = tmax;
  t0 = nx > t0 ? nx : t0;
  t0 = ny > t0 ? ny : t0;
  t0 = nz > t0 ? nz : t0;
  t1 = fx < t1 ? fx : t1;
  t1 = fy < t1 ? fy : t1;
  t1 = fz < t1 ? fz : t1;
  *t_entry = t0;
  *t_exit = t1;
}
TR_FN_INLINE int tr_slab_enters(real nx, real ny, real nz, real fx, real fy, real fz, real tmax,
                                real* t_entry) {
  real t_exit;
  tr_slab_interval(nx, ny, nz, fx, fy, fz, tmax, t_entry, &t_exit);
  return *t_entry <= t_exit;
}

/* Where a ray enters and leaves the box whose near planes (those its direction meets
 * first, as tr_slab_rows picks them) are box_near and far planes box_far, and
 * (tr_ray_enters_box) whether it enters before tmax: the six slab distances from the
 * ray's origin o, reciprocal direction inv_d and its padded copy inv_d_far
 * (tr_box_ray), then tr_slab_interval. In scalars, so that a loop over a
 * node's boxes (tr_ray_hits_planes) or over a packet's rays (tr_packet_rays_in_box)
 * vectorizes on PoCL as well as in g++. */
TR_FN_INLINE void tr_ray_box_interval(vec3 box_near, vec3 box_far, vec3 o, vec3 inv_d,
                                      vec3 inv_d_far, real tmax, real* t_entry, real* t_exit) {
  real nx = (box_near.x - o.x) * inv_d.x;
  real ny = (box_near.y - o.y) * inv_d.y;
  real nz = (box_near.z - o.z) * inv_d.z;
  real fx = (box_far.x - o.x) * inv_d_far.x;
  real fy = (box_far.y - o.y) * inv_d_far.y;
  real fz = (box_far.z - o.z) * inv_d_far.z;
  tr_slab_interval(nx, ny, nz, fx, fy, fz, tmax, t_entry, t_exit);
}
TR_FN_INLINE int tr_ray_enters_box(vec3 box_near, vec3 box_far, vec3 o, vec3 inv_d, vec3 inv_d_far,
                                   real tmax, real* t_entry) {
  real t_exit;
  tr_ray_box_interval(box_near, box_far, o, inv_d, inv_d_far, tmax, t_entry, &t_exit);
  return *t_entry <= t_exit;
}

/* The slab test of one wide node's W boxes (the Williams et al. 2005 slab method; see
 * tr_box_ray), read from the node's rows that the signs of the direction pick
 * (tr_box_planes: once per ray, or once per node for a packet whose rays share the
 * signs): t_entry[k] is where the ray enters child k's box (0 if it starts inside),
 * and bit k of the result says whether it does so before tmax_grown. The loop reads
 * six rows of W contiguous values and has no branch: it vectorizes. A slab
 * distance that is NaN (0 * inf: the origin on a face of a box the ray runs parallel
 * to) fails its compare and narrows nothing. Rounding must never cull a box that holds
 * a primitive the primitive tests would report: the far distances use the padded
 * reciprocal, the caller grows tmax, and the builder pads every box (pack/bvh.hpp). */
TR_FN_INLINE unsigned tr_ray_hits_planes(const TrBoxPlanes* p, const TrBoxRay* br, real tmax_grown,
                                         int W, real* t_entry) {
  unsigned mask = 0u;
  real t_exit[TR_BVH_MAX_WIDTH];
  TR_SIMD_LOOP
  for (int k = 0; k < W; ++k) {
    vec3 box_near = TR_VEC3(p->near_x[k], p->near_y[k], p->near_z[k]);
    vec3 box_far = TR_VEC3(p->far_x[k], p->far_y[k], p->far_z[k]);
    tr_ray_box_interval(box_near, box_far, br->o, br->inv_d, br->inv_d_far, tmax_grown, &t_entry[k],
                        &t_exit[k]);
    /* Without the host's movemask, the mask is set in this loop, not from the stored
     * intervals: g++ then builds it with one vector shift and OR reduction instead of
     * extracting W scalars. */
    if (!TR_HOST_LANE_MASKS) mask |= (unsigned)(t_entry[k] <= t_exit[k]) << k;
  }
  if (TR_HOST_LANE_MASKS) mask = TR_LANES_LE(t_entry, t_exit, W);
  return mask;
}

/* tr_ray_hits_planes with the rows the ray's own direction picks. */
TR_FN_INLINE unsigned tr_ray_hits_boxes(TR_GLOBAL const real* boxes, const TrBoxRay* br,
                                        real tmax_grown, int W, real* t_entry) {
  TrBoxPlanes p = tr_box_planes(boxes, br->rows, W);
  return tr_ray_hits_planes(&p, br, tmax_grown, W, t_entry);
}

/* The inner children a walk goes on to (bits of `inner`, entry distances t_entry), in
 * order[0 .. n), n returned: those entered no later than tmax_grown (a box entered
 * exactly there can hold a tie, and is kept); nearest first (insertion sort into a list
 * of at most W, so a closest-hit walk shortens tmax soon), or in bit order. An any-hit
 * walk may stop at whichever blocker it meets first, so it skips the sort, as Embree's
 * occlusion walk does: 4-5% faster frames on spheres_1e5/1e6 (docs/performance.md).
 * Shared by the ray walk (tr_walk_next) and the packet walk (tr_packet_walk_masked,
 * bvh_packet.h). */
TR_FN_INLINE int tr_inner_order(unsigned inner, const real* t_entry, real tmax_grown,
                                int nearest_first, int* order) {
  int n = 0;
  for (; inner != 0u; inner &= inner - 1u) {
    int k = TR_LOWEST_BIT(inner);
    if (t_entry[k] > tmax_grown) continue;
    int j = n++;
    if (nearest_first)
      for (; j > 0 && t_entry[order[j - 1]] > t_entry[k]; --j) order[j] = order[j - 1];
    order[j] = k;
  }
  return n;
}

/* The node the ray walk visits next: the first of the inner children tr_inner_order
 * gives (node indices first[]), with the others pushed (nearest first: farthest pushed
 * first; bit order: in bit order); else the top of the stack, skipping entries entered
 * beyond tmax_grown. -1 when the walk is done. */
/* The top of the walk's stack, skipping entries entered beyond tmax_grown; -1 when it
 * is empty. Entries below -1 are the instance walk's marks (TR_WALK_ENTER, _LEAVE). */
TR_FN_INLINE int tr_walk_pop(real tmax_grown, const int* stack_node, const real* stack_t,
                             int* top) {
  int next = -1;
  while (next == -1 && *top > 0) {
    --*top;
    if (!(stack_t[*top] > tmax_grown)) next = stack_node[*top];
  }
  return next;
}

TR_FN_INLINE int tr_walk_next(unsigned inner, const real* t_entry, TR_GLOBAL const int* first,
                              real tmax_grown, int nearest_first, int* stack_node, real* stack_t,
                              int* top) {
  int order[TR_BVH_MAX_WIDTH];
  int n = tr_inner_order(inner, t_entry, tmax_grown, nearest_first, order);
  int next = n > 0 ? first[order[0]] : -1;
  for (int i = 1; i < n; ++i) {
    int k = order[nearest_first ? n - i : i];
    if (*top < TR_WALK_STACK_SIZE) {
      stack_node[*top] = first[k];
      stack_t[*top] = t_entry[k];
      ++*top;
    }
  }
  if (next == -1) next = tr_walk_pop(tmax_grown, stack_node, stack_t, top);
  return next;
}

/* Walks the W-wide BVH. Closest hit (any_hit = 0): offers every primitive in the leaves
 * it reaches to *nearest and returns whether there is one. Any hit: returns 1 at the
 * first primitive in (0, nearest->t), computing nothing else.
 * At a node, all W boxes are tested at once; the children the ray enters are then
 * taken from the bit mask, so the work grows with the children hit, not with W. Leaves
 * are tested on the spot (which shortens nearest->t before the inner children are
 * weighed); inner children entered before the nearest hit so far go to tr_walk_next
 * (a closest-hit walk goes on into the nearest, an any-hit walk skips the sort). A
 * popped entry is checked again against the nearest hit found by then (a box entered
 * beyond it cannot hold a nearer hit; one entered at exactly that distance can hold a
 * tie, and is kept). Any order would give the same result (tr_offer_hit); nearest first
 * only saves work. Stack: at most W - 1 entries per inner node on the path
 * (TR_BVH_STACK_SIZE). The triangle test's view of the ray is made at the first leaf:
 * many rays miss every box. With `query` 1 (a constant: ray queries, ray_query.h) the
 * leaves take hits in [tmin, nearest->t] in tr_query_precedes's order, keep the
 * nearest triangle hit's barycentrics in uv[0 .. 2) and skip the objects ray_mask
 * excludes; the renderer passes 0, which leaves none of that in its walk.
 * The walk starts at node `root`. With `instances` 1 (a constant) the tree is the top
 * level (TR_F_INSTANCES): its leaves list instances, each pushed as a mark; a mark
 * taken from the stack maps the ray into the instance's asset (instance.h), pushes a
 * mark to leave it and walks on from the asset's root, so one loop and one stack walk
 * both levels (OpenCL C has no recursion). Hits inside an instance are ordered by
 * (t, instance, primitive) (tr_offer_hit_in). */
TR_FN_INLINE int tr_bvh_walk_wide(const TrSceneRef* s, TrRay ray, TrNearest* nearest, int any_hit,
                                  int W, int query, real tmin, unsigned int ray_mask, int root,
                                  int instances, real* uv) {
  if (root < 0) return 0;
  /* The ray the walk tests boxes and primitives with: the world's, or inside an
   * instance (inst >= 0) the asset's view of it (instance.h). */
  TrRay cur = ray;
  int inst = -1;
  TrBoxRay box_ray = tr_box_ray(ray);
  TrBoxRay world_box_ray = box_ray; /* taken back on leaving an instance */
  TrTriangleRay tri_ray;
  int have_tri_ray = 0;
  real grow = tr_box_grow();
  int stack_node[TR_WALK_STACK_SIZE];
  real stack_t[TR_WALK_STACK_SIZE];
  int top = 0;
  int index = root;
  for (;;) {
    if (instances && index < -1) {
      /* A mark of the top level (instances 1, a constant): enter an instance's asset,
       * or leave it for the world's ray and the rest of the stack. */
      if (index == TR_WALK_LEAVE) {
        cur = ray;
        inst = -1;
        index = -1;
        box_ray = world_box_ray;
      } else {
        inst = TR_WALK_ENTER(0) - index;
        cur = tr_instance_ray(&s->instances[inst], ray);
        stack_node[top] = TR_WALK_LEAVE; /* room: TR_WALK_STACK_SIZE */
        stack_t[top] = TR_R(0.0);
        ++top;
        index = s->instances[inst].root;
        box_ray = tr_box_ray(cur);
      }
      have_tri_ray = 0;
      if (index == -1) {
        index = tr_walk_pop(nearest->t * grow, stack_node, stack_t, &top);
        if (index == -1) break;
        continue;
      }
    }
    TR_GLOBAL const real* node = tr_bvh_node(s, index, W);
    TR_GLOBAL const int* first = tr_bvh_node_links(node, W);
    TR_GLOBAL const int* count = first + W;
    real t_entry[TR_BVH_MAX_WIDTH];
    unsigned mask = tr_ray_hits_boxes(node, &box_ray, nearest->t * grow, W, t_entry);
    tr_prefetch_children(s, mask, first, count, W, instances && inst < 0);
    unsigned inner = 0u, leaves = 0u;
    while (mask != 0u) {
      int k = TR_LOWEST_BIT(mask);
      mask &= mask - 1u;
      if (count[k] <= 0) {
        inner |= count[k] == 0 ? 1u << k : 0u;
        continue;
      }
      if (instances && inst < 0) {
        leaves |= 1u << k; /* a top-level leaf: its instances are marked below */
        continue;
      }
      if (!have_tri_ray) {
        /* Made here, at the first leaf, not at the walk's start (TR_OPAQUE). */
        real dx = cur.d.x, dy = cur.d.y, dz = cur.d.z;
        TR_OPAQUE(dx);
        TR_OPAQUE(dy);
        TR_OPAQUE(dz);
        tri_ray = tr_triangle_ray_dir(TR_VEC3(dx, dy, dz));
        have_tri_ray = 1;
      }
      for (int i = first[k]; i < first[k] + count[k]; ++i) {
        int prim = tr_bvh_prim(s, i);
        if (query && inst < 0 && tr_query_skips(s, prim, ray_mask)) continue;
        vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
        real t = query ? tr_primitive_t_from(s, prim, cur, &tri_ray, tmin, &bary)
                       : tr_primitive_t(s, prim, cur, &tri_ray);
        if (query) {
          if (tr_query_precedes_in(s, t, inst, prim, tmin, nearest->t, nearest->instance,
                                   nearest->prim)) {
            if (any_hit) return 1;
            nearest->t = t;
            nearest->prim = prim;
            nearest->instance = inst;
            uv[0] = bary.y;
            uv[1] = bary.z;
          }
        } else if (any_hit) {
          if (t > TR_R(0.0) && t < nearest->t) return 1;
        } else if (instances) {
          tr_offer_hit_in(s, nearest, t, prim, inst);
        } else {
          tr_offer_hit(nearest, t, prim);
        }
      }
    }
    int next =
        tr_walk_next(inner, t_entry, first, nearest->t * grow, !any_hit, stack_node, stack_t, &top);
    if (instances && leaves != 0u) {
      /* The instances of the top-level leaves the ray enters go first, as marks over
       * the child the walk had picked (put back). Room: TR_WALK_STACK_SIZE. */
      if (next != -1) {
        stack_node[top] = next;
        stack_t[top] = TR_R(0.0);
        ++top;
      }
      /* Farthest leaf first, so that the nearest instance is entered first and its hit
       * shortens the walks of the others. */
      int order[TR_BVH_MAX_WIDTH];
      int n_leaves = tr_inner_order(leaves, t_entry, nearest->t * grow, 1, order);
      for (int j = n_leaves - 1; j >= 0; --j) {
        int k = order[j];
        for (int i = first[k]; i < first[k] + count[k]; ++i) {
          if (query && tr_use(s, TR_F_MASKS) && (s->instances[i].mask & ray_mask) == 0u) continue;
          stack_node[top] = TR_WALK_ENTER(i);
          stack_t[top] = t_entry[k];
          ++top;
        }
      }
      next = tr_walk_pop(nearest->t * grow, stack_node, stack_t, &top);
    }
    if (next == -1) break;
    index = next;
  }
  return any_hit ? 0 : nearest->prim >= 0;
}

/* The walk over the scene's own primitives, then (TR_F_INSTANCES) over its instances:
 * two trees, one walk each. */
TR_FN_INLINE int tr_bvh_walk_roots(const TrSceneRef* s, TrRay ray, TrNearest* nearest, int any_hit,
                                   int W, int query, real tmin, unsigned int ray_mask, real* uv) {
  int scene_root =
      TR_HAS(TR_F_INSTANCES) ? s->params->scene_root : (s->params->n_bvh_nodes > 0 ? 0 : -1);
  int found =
      tr_bvh_walk_wide(s, ray, nearest, any_hit, W, query, tmin, ray_mask, scene_root, 0, uv);
  if (!TR_HAS(TR_F_INSTANCES)) return found;
  if (found && any_hit) return 1;
  found = tr_bvh_walk_wide(s, ray, nearest, any_hit, W, query, tmin, ray_mask,
                           s->params->instance_root, 1, uv);
  return any_hit ? found : nearest->prim >= 0;
}

/* The walk for the width the scene's BVH was built with. Each width is compiled only
 * where the Features mask holds its bit; callers pass any_hit as a constant, so closest
 * hit and any hit each get a walk of their own. */
TR_FN_INLINE int tr_bvh_walk(const TrSceneRef* s, TrRay ray, TrNearest* nearest, int any_hit) {
  unsigned int all = 0xffffffffu;
  if (tr_use(s, TR_F_BVH8))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 8, 0, TR_R(0.0), all, 0);
  if (tr_use(s, TR_F_BVH4))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 4, 0, TR_R(0.0), all, 0);
  if (tr_use(s, TR_F_BVH2))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 2, 0, TR_R(0.0), all, 0);
  return 0;
}

/* The walk of a ray query (ray_query.h): hits in [tmin, nearest->t] ordered by
 * tr_query_precedes, objects the ray's mask excludes skipped; the nearest triangle
 * hit's barycentrics of vertices 1 and 2 in uv[0], uv[1]. */
TR_FN_INLINE int tr_bvh_walk_query(const TrSceneRef* s, TrRay ray, TrNearest* nearest, int any_hit,
                                   real tmin, unsigned int ray_mask, real* uv) {
  if (tr_use(s, TR_F_BVH8))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 8, 1, tmin, ray_mask, uv);
  if (tr_use(s, TR_F_BVH4))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 4, 1, tmin, ray_mask, uv);
  if (tr_use(s, TR_F_BVH2))
    return tr_bvh_walk_roots(s, ray, nearest, any_hit, 2, 1, tmin, ray_mask, uv);
  return 0;
}
