/* Closest hits and shadow tests of a packet of coherent rays (up to TR_PACKET_MAX: one
 * block of camera rays, or its shadow rays toward one light) in one walk of the W-wide
 * BVH: the walk of coherent ray streams (tr_packet_walk_masked), which reads each node
 * once for all the rays that reach it.
 *
 * A node's W boxes are first tested once for the whole packet, against the interval
 * that holds every ray's origin and reciprocal direction (all rays' directions have the
 * same sign on each axis, or the packet is walked ray by ray): interval culling, after
 * Wald, Boulos and Shirley, "Ray Tracing Deformable Scenes Using Dynamic Bounding
 * Volume Hierarchies" (ACM TOG 26(1), 2007), and Overbeck, Ramamoorthi and Mark, "Large
 * Ray Packets for Real-Time Whitted Ray Tracing" (IRT 2008). The interval test is
 * conservative against each ray's own box test in floating point, not only in real
 * numbers: rounding is monotonic, so fl(B - o) lies between fl(B - o_hi) and
 * fl(B - o_lo), and fl(x y) between the least and greatest of the rounded products of
 * the bounds. If no ray's own test (tr_ray_hits_boxes) could enter a box, the packet's
 * does not either. The rays' own tests then decide, the very operations of
 * tr_ray_hits_boxes, one ray per SIMD lane, and each ray is offered the primitives of
 * exactly the leaves its own test enters (a leaf's primitives are tested a ray per
 * lane for each group of rays that holds enough of those that entered it, the hits
 * kept where the ray entered, and for the entering rays of other groups one ray at a
 * time). The image is the same bits as the single-ray walk's
 * (tests/pack/packet_test.cpp). */

/* The greatest (greatest = 1) or the least (0) of a[0 .. n), n >= 1: eight running
 * extremes side by side (one vector register) instead of one chain of dependent
 * compares. Callers pass `greatest` as a constant, so the compare folds. The values are
 * never NaN where the result matters (a NaN ray makes its packet incoherent). */
TR_FN_INLINE real tr_lanes_extreme(const real* a, int n, int greatest) {
  real m[8];
  int r = 0;
  for (int j = 0; j < 8; ++j) m[j] = a[0];
  for (; r + 8 <= n; r += 8) {
    TR_SIMD_LOOP
    for (int j = 0; j < 8; ++j) {
      real x = a[r + j];
      m[j] = (greatest ? x > m[j] : x < m[j]) ? x : m[j];
    }
  }
  for (; r < n; ++r) m[0] = (greatest ? a[r] > m[0] : a[r] < m[0]) ? a[r] : m[0];
  for (int j = 1; j < 8; ++j) m[0] = (greatest ? m[j] > m[0] : m[j] < m[0]) ? m[j] : m[0];
  return m[0];
}
TR_FN_INLINE real tr_lanes_min(const real* a, int n) {
  return tr_lanes_extreme(a, n, 0);
}
TR_FN_INLINE real tr_lanes_max(const real* a, int n) {
  return tr_lanes_extreme(a, n, 1);
}

/* The rays of a packet are tested against one box in groups of TR_PACKET_GROUP, one
 * vector of floats per group on AVX-512 (tr_packet_rays_in_box); a group with no ray
 * in the test's mask is skipped. tr_packet_groups_end(n) is n rounded up to a whole
 * group. */
#define TR_PACKET_GROUP 16
TR_FN_INLINE int tr_packet_groups_end(int n) {
  return (n + TR_PACKET_GROUP - 1) / TR_PACKET_GROUP * TR_PACKET_GROUP;
}

/* Ray r into the packet's arrays, one per component (tr_packet_begin). */
TR_FN_INLINE void tr_packet_set_ray(TrRayPacket* pk, int r, TrRay ray) {
  pk->ox[r] = ray.o.x;
  pk->oy[r] = ray.o.y;
  pk->oz[r] = ray.o.z;
  pk->dx[r] = ray.d.x;
  pk->dy[r] = ray.d.y;
  pk->dz[r] = ray.d.z;
}

/* Ray r, read back from the packet's arrays (tr_packet_begin). */
TR_FN_INLINE TrRay tr_packet_ray(const TrRayPacket* pk, int r) {
  TrRay ray;
  ray.o = TR_VEC3(pk->ox[r], pk->oy[r], pk->oz[r]);
  ray.d = TR_VEC3(pk->dx[r], pk->dy[r], pk->dz[r]);
  return ray;
}

/* Fills the packet's derived fields from pk->ray[0 .. n) (pk->t and pk->prim are the
 * caller's: each ray's tmax and -1): each ray's box-test view (tr_box_ray's values) and
 * triangle-test view (tr_triangle_ray's), and the packet's bounds. Returns whether the
 * packet can be walked as one: every direction component nonzero and of the same sign
 * across the packet, every reciprocal finite.
 * The rays' components go into one array each first, so that the rest runs a ray per
 * SIMD lane: six divisions per ray, done one at a time, took a third of a packet query
 * on the demo frame (docs/performance.md). */
TR_FN int tr_packet_begin(TrRayPacket* pk) {
  int n = pk->n;
  if (n <= 0) return 0;
  /* Read as reals at the rays' stride (d follows o at sizeof(vec3)), so that clang
   * vectorizes the copy as one interleaved group, 16 rays per step; over whole rays
   * (tr_packet_set_ray) it went a ray at a time, six scalar stores each: about half of
   * this function's samples on mesh_1e4 (docs/performance.md). */
  {
    const real* rays = (const real*)pk->ray;
    const int stride = (int)(sizeof(TrRay) / sizeof(real)), d = (int)(sizeof(vec3) / sizeof(real));
    TR_INDEPENDENT_LOOP
    for (int r = 0; r < n; ++r) {
      pk->ox[r] = rays[r * stride];
      pk->oy[r] = rays[r * stride + 1];
      pk->oz[r] = rays[r * stride + 2];
      pk->dx[r] = rays[r * stride + d];
      pk->dy[r] = rays[r * stride + d + 1];
      pk->dz[r] = rays[r * stride + d + 2];
    }
  }
  vec3 d0 = TR_VEC3(pk->dx[0], pk->dy[0], pk->dz[0]);
  real grow = tr_box_grow();
  int incoherent = 0;
  if (TR_HAS(TR_F_TRIANGLES)) {
    TR_LANE_LOOP
    for (int r = 0; r < n; ++r) {
      TrTriangleRay tr = tr_triangle_ray_dir(TR_VEC3(pk->dx[r], pk->dy[r], pk->dz[r]));
      pk->tri_sx[r] = tr.sx;
      pk->tri_sy[r] = tr.sy;
      pk->tri_sz[r] = tr.sz;
      pk->tri_kx[r] = tr.kx;
      pk->tri_ky[r] = tr.ky;
      pk->tri_kz[r] = tr.kz;
    }
  }
  /* In scalars: over TrBoxRay's float3 fields, LLVM's loop vectorizer left this loop
   * scalar on PoCL. */
  TR_LANE_LOOP
  for (int r = 0; r < n; ++r) {
    real dx = pk->dx[r], dy = pk->dy[r], dz = pk->dz[r];
    real ix = tr_box_inv(dx), iy = tr_box_inv(dy), iz = tr_box_inv(dz);
    real fx = tr_box_inv_far(ix), fy = tr_box_inv_far(iy), fz = tr_box_inv_far(iz);
    pk->ix[r] = ix;
    pk->iy[r] = iy;
    pk->iz[r] = iz;
    pk->fx[r] = fx;
    pk->fy[r] = fy;
    pk->fz[r] = fz;
    real afx = tr_fabs(fx), afy = tr_fabs(fy), afz = tr_fabs(fz);
    int coherent = (dx * d0.x > TR_R(0.0)) & (dy * d0.y > TR_R(0.0)) & (dz * d0.z > TR_R(0.0)) &
                   (afx < TR_R(INFINITY)) & (afy < TR_R(INFINITY)) & (afz < TR_R(INFINITY));
    incoherent |= !coherent;
  }
  /* The lanes past n up to a multiple of TR_PACKET_GROUP, which the group loops of
   * tr_packet_rays_in_box read: a copy of ray 0 that never enters a box (t < 0). */
  for (int r = n; r < tr_packet_groups_end(n); ++r) {
    pk->ox[r] = pk->ox[0];
    pk->oy[r] = pk->oy[0];
    pk->oz[r] = pk->oz[0];
    pk->ix[r] = pk->ix[0];
    pk->iy[r] = pk->iy[0];
    pk->iz[r] = pk->iz[0];
    pk->fx[r] = pk->fx[0];
    pk->fy[r] = pk->fy[0];
    pk->fz[r] = pk->fz[0];
    pk->t[r] = TR_R(-1.0);
  }
  pk->o_lo = TR_VEC3(tr_lanes_min(pk->ox, n), tr_lanes_min(pk->oy, n), tr_lanes_min(pk->oz, n));
  pk->o_hi = TR_VEC3(tr_lanes_max(pk->ox, n), tr_lanes_max(pk->oy, n), tr_lanes_max(pk->oz, n));
  pk->i_lo = TR_VEC3(tr_lanes_min(pk->ix, n), tr_lanes_min(pk->iy, n), tr_lanes_min(pk->iz, n));
  pk->i_hi = TR_VEC3(tr_lanes_max(pk->ix, n), tr_lanes_max(pk->iy, n), tr_lanes_max(pk->iz, n));
  /* x -> fl(x grow) is monotonic (grow > 0), so these are the bounds of fx..fz. */
  pk->f_lo = pk->i_lo * grow;
  pk->f_hi = pk->i_hi * grow;
  pk->rows = tr_slab_rows(TR_VEC3(pk->ix[0], pk->iy[0], pk->iz[0]));
  return !incoherent;
}

/* Ray r's triangle-test view (tr_packet_begin). */
TR_FN_INLINE TrTriangleRay tr_packet_triangle_ray(const TrRayPacket* pk, int r) {
  TrTriangleRay tr;
  tr.sx = pk->tri_sx[r];
  tr.sy = pk->tri_sy[r];
  tr.sz = pk->tri_sz[r];
  tr.kx = pk->tri_kx[r];
  tr.ky = pk->tri_ky[r];
  tr.kz = pk->tri_kz[r];
  return tr;
}

/* The least and greatest of the rounded products x y over x in [x_lo, x_hi] and y in
 * [y_lo, y_hi]: attained at the corners, since rounding is monotonic. */
TR_FN_INLINE real tr_interval_mul_lo(real x_lo, real x_hi, real y_lo, real y_hi) {
  real a = x_lo * y_lo, b = x_lo * y_hi, c = x_hi * y_lo, d = x_hi * y_hi;
  real m = a < b ? a : b;
  m = c < m ? c : m;
  return d < m ? d : m;
}
TR_FN_INLINE real tr_interval_mul_hi(real x_lo, real x_hi, real y_lo, real y_hi) {
  real a = x_lo * y_lo, b = x_lo * y_hi, c = x_hi * y_lo, d = x_hi * y_hi;
  real m = a > b ? a : b;
  m = c > m ? c : m;
  return d > m ? d : m;
}

/* The packet's test of one wide node's W boxes: bit k set unless no ray of the packet
 * can enter child k before tmax_grown (the greatest of the rays' grown nearest hits);
 * t_entry[k] a lower bound on where any of them enters it. Bit k of *ahead is set where
 * child k's box lies ahead of every ray's origin on all three axes: each near slab
 * distance is > 0 for the whole packet. Then, for any point p in the box and any axis,
 * a ray's rounded depth fl(fl(p - o) i) (i its reciprocal direction on that axis) is
 * > 0 too: p lies beyond the near plane, and rounding is monotonic. That depth is
 * tr_triangle_hit_at's az, bz, cz (its sz is the same reciprocal), so the triangles of
 * such a leaf need no straddle bound. */
TR_FN_INLINE unsigned tr_packet_hits_boxes(TR_GLOBAL const real* boxes, const TrRayPacket* pk,
                                           real tmax_grown, int W, real* t_entry, unsigned* ahead) {
  TrBoxPlanes p = tr_box_planes(boxes, pk->rows, W);
  vec3 o_lo = pk->o_lo, o_hi = pk->o_hi, i_lo = pk->i_lo, i_hi = pk->i_hi;
  vec3 f_lo = pk->f_lo, f_hi = pk->f_hi;
  unsigned mask = 0u, in_front = 0u;
  TR_SIMD_LOOP
  for (int k = 0; k < W; ++k) {
    real nx = tr_interval_mul_lo(p.near_x[k] - o_hi.x, p.near_x[k] - o_lo.x, i_lo.x, i_hi.x);
    real ny = tr_interval_mul_lo(p.near_y[k] - o_hi.y, p.near_y[k] - o_lo.y, i_lo.y, i_hi.y);
    real nz = tr_interval_mul_lo(p.near_z[k] - o_hi.z, p.near_z[k] - o_lo.z, i_lo.z, i_hi.z);
    real fx = tr_interval_mul_hi(p.far_x[k] - o_hi.x, p.far_x[k] - o_lo.x, f_lo.x, f_hi.x);
    real fy = tr_interval_mul_hi(p.far_y[k] - o_hi.y, p.far_y[k] - o_lo.y, f_lo.y, f_hi.y);
    real fz = tr_interval_mul_hi(p.far_z[k] - o_hi.z, p.far_z[k] - o_lo.z, f_lo.z, f_hi.z);
    mask |= (unsigned)tr_slab_enters(nx, ny, nz, fx, fy, fz, tmax_grown, &t_entry[k]) << k;
    in_front |= (unsigned)((nx > TR_R(0.0)) & (ny > TR_R(0.0)) & (nz > TR_R(0.0))) << k;
  }
  *ahead = in_front;
  return mask;
}

/* Primitive prim, which ray r hits at t if `hit`, offered to the ray, in a loop that
 * runs a ray per SIMD lane: tr_offer_hit's order (closest hit), or the blocked mark
 * (any hit: t in (0, pk->t[r]) sets pk->t[r] to -1), as selects. any_hit is data, not a
 * branch, so that the loop stays one basic block. */
TR_FN_INLINE void tr_packet_offer(TrRayPacket* pk, int r, int hit, real t, int prim, int any_hit) {
  real t_r = pk->t[r];
  int prim_r = pk->prim[r];
  int blocked = any_hit & hit & (t > TR_R(0.0)) & (t < t_r);
  int nearer = (any_hit == 0) & hit & tr_hit_precedes(t, prim, t_r, prim_r);
  pk->t[r] = blocked ? TR_R(-1.0) : nearer ? t : t_r;
  pk->prim[r] = nearer ? prim : prim_r;
}

/* The same for a ray query (ray_query.h), whose tmin and mask q holds: t counts where
 * t > 0, t >= the ray's tmin and t <= its nearest hit so far (or its tmax: the interval
 * is closed), and `sees` (the ray's mask shares a bit with the object's). Closest hit:
 * a smaller t, or any such t while the ray has no hit yet, is taken here; returns 1 for
 * a tie of t with the ray's nearest hit, which tr_query_precedes settles outside the
 * lanes (it reads both primitives' object and face). Any hit: such a t blocks the ray
 * (pk->t[r] = -1). A nearer hit's (u, v) (a triangle's barycentrics) go to pk->u[r],
 * pk->v[r]. */
TR_FN_INLINE int tr_packet_query_offer(TrRayPacket* pk, const TrQueryLanes* q, int r, int hit,
                                       int sees, real t, int prim, int any_hit, real u, real v) {
  real t_r = pk->t[r];
  int prim_r = pk->prim[r];
  int counts = hit & sees & (t > TR_R(0.0)) & (t >= q->tmin[r]) & (t <= t_r);
  int first = (t < t_r) | (prim_r < 0);
  int blocked = any_hit & counts;
  int nearer = (any_hit == 0) & counts & first;
  pk->t[r] = blocked ? TR_R(-1.0) : nearer ? t : t_r;
  pk->prim[r] = nearer ? prim : prim_r;
  if (!any_hit) {
    pk->u[r] = nearer ? u : pk->u[r];
    pk->v[r] = nearer ? v : pk->v[r];
  }
  return (any_hit == 0) & counts & !first;
}

/* A tie of primitive prim's t with ray r's nearest hit (tr_packet_query_offer): prim
 * takes it where it comes first in tr_query_precedes's order of (object, face), and a
 * triangle's barycentrics come from the ray's own test of it (the lanes' values: the
 * same operations). */
TR_FN_INLINE void tr_packet_query_tie(const TrSceneRef* s, TrRayPacket* pk, const TrQueryLanes* q,
                                      int r, int prim) {
  if (!tr_query_precedes(s, pk->t[r], prim, q->tmin[r], pk->t[r], pk->prim[r])) return;
  pk->prim[r] = prim;
  int triangle = prim - s->params->n_spheres;
  if (TR_HAS(TR_F_TRIANGLES) && triangle >= 0) {
    TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
    vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    tr_triangle_t_bary(&s->triangles[triangle], pk->ray[r], &tri_ray, &bary);
    pk->u[r] = bary.y;
    pk->v[r] = bary.z;
  }
}

/* Whether ray r of a query packet sees an object of mask object_mask (tr_query_skips);
 * 1 where masks is 0 (the scene has none). */
TR_FN_INLINE int tr_packet_query_sees(const TrQueryLanes* q, int r, int masks,
                                      unsigned int object_mask) {
  return (masks == 0) | ((object_mask & q->mask[r]) != 0u);
}

/* Triangle p0 p1 p2 (primitive prim) offered to each ray r of the group of
 * TR_PACKET_GROUP rays from ray g with enter[r] set, a ray per SIMD lane:
 * tr_triangle_hit_at without branches (may_straddle a constant), then tr_packet_offer,
 * or for a ray query (`query` a constant; q its rays' tmin and mask, masks and
 * object_mask as in tr_packet_query_sees) tr_packet_query_offer. The group's other
 * rays are computed and dropped. Returns the ties of a closest-hit query (bit j: ray
 * g + j), which the caller settles. */
TR_FN_INLINE unsigned tr_packet_triangle_lanes_of(TrRayPacket* pk, vec3 p0, vec3 p1, vec3 p2,
                                                  int prim, const int* enter, int g, int any_hit,
                                                  int may_straddle, int query,
                                                  const TrQueryLanes* q, int masks,
                                                  unsigned int object_mask) {
  unsigned ties = 0u;
  TR_LANE_LOOP
  for (int r = g; r < g + TR_PACKET_GROUP; ++r) {
    TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
    vec3 bary;
    real t;
    int hit = enter[r] & tr_triangle_hit_at(p0, p1, p2, TR_VEC3(pk->ox[r], pk->oy[r], pk->oz[r]),
                                            &tri_ray, 0, may_straddle, &t, &bary);
    if (query)
      ties |= (unsigned)tr_packet_query_offer(pk, q, r, hit,
                                              tr_packet_query_sees(q, r, masks, object_mask), t,
                                              prim, any_hit, bary.y, bary.z)
              << (r - g);
    else
      tr_packet_offer(pk, r, hit, t, prim, any_hit);
  }
  return ties;
}

/* Triangle prim offered to the group's rays as above; `ahead` where its leaf's box lies
 * ahead of every ray of the packet (tr_packet_hits_boxes), which lets the lanes skip
 * the straddle bound. */
TR_FN_INLINE unsigned tr_packet_triangle_lanes(const TrSceneRef* s, TrRayPacket* pk, int prim,
                                               const int* enter, int g, int any_hit, int ahead,
                                               int query, const TrQueryLanes* q, int masks,
                                               unsigned int object_mask) {
  TR_GLOBAL const TrTriangle* tri = &s->triangles[prim - s->params->n_spheres];
  vec3 p0 = tr_triangle_p0(tri), p1 = tr_triangle_p1(tri), p2 = tr_triangle_p2(tri);
  if (ahead)
    return tr_packet_triangle_lanes_of(pk, p0, p1, p2, prim, enter, g, any_hit, 0, query, q, masks,
                                       object_mask);
  return tr_packet_triangle_lanes_of(pk, p0, p1, p2, prim, enter, g, any_hit, 1, query, q, masks,
                                     object_mask);
}

/* Sphere prim offered to each ray r of the group from ray g with enter[r] set, a ray
 * per SIMD lane, as tr_packet_triangle_lanes does for triangles; for a ray query, the
 * sphere's first crossing from the ray's tmin on (tr_sphere_t_from). */
TR_FN_INLINE unsigned tr_packet_sphere_lanes(const TrSceneRef* s, TrRayPacket* pk, int prim,
                                             const int* enter, int g, int any_hit, int query,
                                             const TrQueryLanes* q, int masks,
                                             unsigned int object_mask) {
  TR_GLOBAL const TrSphere* sp = &s->spheres[prim];
  vec3 center = tr_sphere_center(sp);
  real radius = sp->radius;
  unsigned ties = 0u;
  TR_LANE_LOOP
  for (int r = g; r < g + TR_PACKET_GROUP; ++r) {
    real t;
    if (query) {
      int hit =
          enter[r] & tr_sphere_hit_from(center, radius, tr_packet_ray(pk, r), 0, 1, q->tmin[r], &t);
      ties |= (unsigned)tr_packet_query_offer(pk, q, r, hit,
                                              tr_packet_query_sees(q, r, masks, object_mask), t,
                                              prim, any_hit, TR_R(0.0), TR_R(0.0))
              << (r - g);
    } else {
      int hit = enter[r] & tr_sphere_hit_at(center, radius, tr_packet_ray(pk, r), 0, &t);
      tr_packet_offer(pk, r, hit, t, prim, any_hit);
    }
  }
  return ties;
}

/* A leaf's primitives bvh_prims[first .. first + count) offered to the rays of `in`
 * (bit r: ray r; enter[r] set for each of them, clear for the packet's other rays):
 * closest hit or any hit as in tr_packet_offer. Each primitive is tested a ray per
 * SIMD lane for each group of TR_PACKET_GROUP rays that holds at least
 * TR_LANE_GROUP_MIN_RAYS of them (prelude.h), and for the rays of a group that holds
 * fewer, one ray at a time. On AVX-512 that is every group that holds one: a test
 * without branches over 16 lanes, one vector, took less time than even one ray's
 * scalar test, whose branches on a mesh's small triangles go either way (mesh_1e6,
 * docs/performance.md). The lane loops vectorize in g++ and on
 * PoCL alike, since the primitive tests compute in scalars (LLVM does not widen
 * float3). `ahead`: the leaf's box lies ahead of every ray of the packet
 * (tr_packet_hits_boxes). A ray query (`query` a constant, q its rays' tmin and mask)
 * takes hits as tr_bvh_walk_query's leaves do: in [tmin, nearest] in
 * tr_query_precedes's order, objects the ray's mask excludes skipped. */
TR_FN_INLINE void tr_packet_leaf(const TrSceneRef* s, TrRayPacket* pk, int first, int count,
                                 tr_mask64 in, const int* enter, int any_hit, int ahead, int query,
                                 const TrQueryLanes* q) {
  /* Bit g set for each group (from ray g) tested in lanes; the other rays of `in` go
   * one at a time. With a minimum of one ray, every group that holds one. */
  tr_mask64 lane_groups = 0, lone_rays = 0;
  for (int g = 0; g < pk->n; g += TR_PACKET_GROUP) {
    unsigned group = (unsigned)(in >> g) & ((1u << TR_PACKET_GROUP) - 1u);
    if (TR_LANE_GROUP_MIN_RAYS <= 1 || TR_POPCOUNT(group) >= TR_LANE_GROUP_MIN_RAYS)
      lane_groups |= (tr_mask64)(group != 0u) << g;
    else
      lone_rays |= (tr_mask64)group << g;
  }
  int masks = query && tr_use(s, TR_F_MASKS);
  for (int i = first; i < first + count; ++i) {
    int prim = tr_bvh_prim(s, i);
    int sphere = TR_HAS(TR_F_SPHERES) && prim < s->params->n_spheres;
    unsigned int object_mask = masks ? s->object_masks[tr_query_object(s, prim)] : 0xffffffffu;
    for (tr_mask64 m = lane_groups; m != 0; m &= m - 1) {
      int g = TR_LOWEST_BIT64(m);
      unsigned ties = 0u;
      if (sphere)
        ties = tr_packet_sphere_lanes(s, pk, prim, enter, g, any_hit, query, q, masks, object_mask);
      else if (TR_HAS(TR_F_TRIANGLES))
        ties = tr_packet_triangle_lanes(s, pk, prim, enter, g, any_hit, ahead, query, q, masks,
                                        object_mask);
      if (query)
        for (; ties != 0u; ties &= ties - 1u)
          tr_packet_query_tie(s, pk, q, g + TR_LOWEST_BIT(ties), prim);
    }
    /* One ray at a time, the offer keeps its branches: most tests miss, and the selects
     * of tr_packet_offer made spheres_1e5 frames 7% slower here (docs/performance.md). */
    for (tr_mask64 m = lone_rays; m != 0; m &= m - 1) {
      int r = TR_LOWEST_BIT64(m);
      if (any_hit && pk->t[r] < TR_R(0.0)) continue; /* blocked by an earlier primitive */
      TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
      if (query) {
        /* tr_bvh_walk_wide's leaf step for one query ray */
        if (!tr_packet_query_sees(q, r, masks, object_mask)) continue;
        vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
        real t = tr_primitive_t_from(s, prim, pk->ray[r], &tri_ray, q->tmin[r], &bary);
        if (tr_query_precedes(s, t, prim, q->tmin[r], pk->t[r], pk->prim[r])) {
          pk->t[r] = any_hit ? TR_R(-1.0) : t;
          pk->prim[r] = any_hit ? pk->prim[r] : prim;
          pk->u[r] = bary.y;
          pk->v[r] = bary.z;
        }
        continue;
      }
      real t = tr_primitive_t(s, prim, pk->ray[r], &tri_ray);
      if (any_hit) {
        if (t > TR_R(0.0) && t < pk->t[r]) pk->t[r] = TR_R(-1.0);
        continue;
      }
      TrNearest nearest = tr_nearest(pk->t[r], pk->prim[r]);
      tr_offer_hit(&nearest, t, prim);
      pk->t[r] = nearest.t;
      pk->prim[r] = nearest.prim;
    }
  }
}

/* The rays of `rays` (bit r: ray r) that enter child k's box before their own nearest
 * hits so far (grown): each ray's own test, tr_ray_enters_box as tr_ray_hits_boxes
 * makes it, a ray per SIMD lane, TR_PACKET_GROUP rays at a time; a group with none of
 * `rays` is skipped (the lanes past n, which tr_packet_begin pads, are never in it).
 * Sets enter[r], for each ray r of the groups tested, to whether ray r is one of them
 * (the groups skipped are left as they were: their rays are not in the result, and
 * tr_packet_leaf reads only the groups that hold one). */
TR_FN_INLINE tr_mask64 tr_packet_rays_in_box(TR_GLOBAL const real* boxes, const TrRayPacket* pk,
                                             int W, int k, tr_mask64 rays, int* enter) {
  TrBoxPlanes p = tr_box_planes(boxes, pk->rows, W);
  vec3 box_near = TR_VEC3(p.near_x[k], p.near_y[k], p.near_z[k]);
  vec3 box_far = TR_VEC3(p.far_x[k], p.far_y[k], p.far_z[k]);
  real grow = tr_box_grow();
  tr_mask64 in = 0;
  for (int g = 0; g < pk->n; g += TR_PACKET_GROUP) {
    unsigned group_rays = (unsigned)(rays >> g) & ((1u << TR_PACKET_GROUP) - 1u);
    if (group_rays == 0u) continue;
    unsigned group_in = 0u;
    TR_LANE_LOOP
    for (int j = 0; j < TR_PACKET_GROUP; ++j) {
      int r = g + j;
      vec3 o = TR_VEC3(pk->ox[r], pk->oy[r], pk->oz[r]);
      vec3 inv_d = TR_VEC3(pk->ix[r], pk->iy[r], pk->iz[r]);
      vec3 inv_d_far = TR_VEC3(pk->fx[r], pk->fy[r], pk->fz[r]);
      real t_entry;
      int e = tr_ray_enters_box(box_near, box_far, o, inv_d, inv_d_far, pk->t[r] * grow, &t_entry) &
              (int)((group_rays >> j) & 1u);
      enter[r] = e;
      group_in |= (unsigned)e << j;
    }
    in |= (tr_mask64)group_in << g;
  }
  return in;
}

/* The greatest of the packet's nearest distances, grown as the box test grows them. */
TR_FN_INLINE real tr_packet_tmax_grown(const TrRayPacket* pk) {
  return tr_lanes_max(pk->t, pk->n) * tr_box_grow();
}

/* Ray r's box-test view (tr_box_ray's values, from tr_packet_begin's arrays). */
TR_FN_INLINE TrBoxRay tr_packet_box_ray(const TrRayPacket* pk, int r) {
  TrBoxRay br;
  br.o = TR_VEC3(pk->ox[r], pk->oy[r], pk->oz[r]);
  br.inv_d = TR_VEC3(pk->ix[r], pk->iy[r], pk->iz[r]);
  br.inv_d_far = TR_VEC3(pk->fx[r], pk->fy[r], pk->fz[r]);
  br.rows = tr_slab_rows(br.inv_d);
  return br;
}

/* Walks the W-wide BVH once for the rays of a coherent packet (tr_packet_begin returned
 * 1) in `active` (bit r: ray r), with a mask of rays per stack entry, as Embree's walk
 * of coherent ray streams does (BVHNIntersectorStream::intersectCoherent, after Wald,
 * Gribble, Boulos, Kensler, "SIMD Ray Stream Tracing", 2007; Fuetterling, Lojewski,
 * Pfreundt, Ebert, "Efficient Ray Tracing Kernels for Modern CPU Architectures", JCGT
 * 4(4), 2015). At a node, the packet's interval test (tr_packet_hits_boxes) drops the
 * children no ray can enter, and one ray known to enter the node (its `lead`) takes its
 * own box test. An inner child the lead enters goes on with the node's rays as they
 * are; any other goes on only with the node's rays whose own box tests enter it
 * (tr_packet_rays_in_box), and is dropped if there are none. A leaf is offered to the
 * rays whose own box tests enter it. So no node is visited that no ray enters, and
 * each ray is offered exactly the leaves its own box test enters (a box's test fails
 * for a ray whose test of an enclosing box failed: rounding is monotonic, and a ray's
 * nearest hit only shrinks): the answers are tr_bvh_walk's, bit for bit (tr_offer_hit's
 * order; any hit: blocked or not), and rays outside `active` are left untouched. Where
 * a node's rays each took their own test of its children instead, mesh_1e6 frames took
 * 1.08 times as long (docs/performance.md). Inner children go nearest first by the
 * packet's entry bound (closest hit), or in bit order (any hit): tr_inner_order.
 * Bit order is the collapse's left to right; for shadow rays, nearest first took 1.08-1.10
 * times as long on the benchmark scenes, and the best order depends on where the light
 * is (docs/performance.md). With `query` 1 (a constant; q the rays' tmin and mask) the
 * leaves take hits as a ray query's walk does (tr_packet_leaf), and the answers are
 * tr_bvh_walk_query's; the renderer passes 0 and a null q. */
TR_FN_INLINE void tr_packet_walk_masked(const TrSceneRef* s, TrRayPacket* pk, tr_mask64 active,
                                        int any_hit, int W, int query, const TrQueryLanes* q) {
  if (s->params->n_bvh_nodes <= 0 || active == 0) return;
  int stack_node[TR_BVH_STACK_SIZE], stack_lead[TR_BVH_STACK_SIZE];
  real stack_t[TR_BVH_STACK_SIZE];
  tr_mask64 stack_rays[TR_BVH_STACK_SIZE];
  TR_ALIGNED(TR_LINE_BYTES) int enter[TR_PACKET_MAX];
  real grow = tr_box_grow();
  real tmax_grown = tr_packet_tmax_grown(pk);
  int top = 0;
  int index = 0;
  tr_mask64 live = active; /* any hit: the rays not blocked yet */
  tr_mask64 node_rays = active;
  int lead = TR_LOWEST_BIT64(active);
  for (;;) {
    TR_GLOBAL const real* boxes = tr_bvh_node(s, index, W);
    TR_GLOBAL const int* first = tr_bvh_node_links(boxes, W);
    TR_GLOBAL const int* count = first + W;
    real t_entry[TR_BVH_MAX_WIDTH];
    unsigned ahead = 0u;
    unsigned mask = tr_packet_hits_boxes(boxes, pk, tmax_grown, W, t_entry, &ahead);
    unsigned lead_enters = 0u;
    if (mask != 0u) {
      TrBoxPlanes planes = tr_box_planes(boxes, pk->rows, W);
      TrBoxRay lead_ray = tr_packet_box_ray(pk, lead);
      real lead_t[TR_BVH_MAX_WIDTH];
      lead_enters = tr_ray_hits_planes(&planes, &lead_ray, pk->t[lead] * grow, W, lead_t);
    }
    tr_mask64 child_rays[TR_BVH_MAX_WIDTH];
    int child_lead[TR_BVH_MAX_WIDTH];
    unsigned inner = 0u;
    int leaves_tested = 0;
    while (mask != 0u) {
      int k = TR_LOWEST_BIT(mask);
      mask &= mask - 1u;
      if (count[k] < 0) continue; /* an empty slot */
      if (count[k] == 0 && ((lead_enters >> k) & 1u)) {
        child_rays[k] = node_rays;
        child_lead[k] = lead;
        inner |= 1u << k;
        continue;
      }
      tr_mask64 in = tr_packet_rays_in_box(boxes, pk, W, k, node_rays, enter);
      if (in == 0) continue;
      if (count[k] == 0) {
        child_rays[k] = in;
        child_lead[k] = TR_LOWEST_BIT64(in);
        inner |= 1u << k;
        continue;
      }
      leaves_tested = 1;
      tr_packet_leaf(s, pk, first[k], count[k], in, enter, any_hit, (int)((ahead >> k) & 1u), query,
                     q);
    }
    if (leaves_tested) {
      tmax_grown = tr_packet_tmax_grown(pk);
      if (any_hit) {
        if (tmax_grown < TR_R(0.0)) break; /* every ray is blocked */
        tr_mask64 unblocked = 0;
        for (int r = 0; r < pk->n; ++r) unblocked |= (tr_mask64)(pk->t[r] >= TR_R(0.0)) << r;
        live &= unblocked;
      }
    }
    /* The next node: the first inner child (nearest first for closest hits), the
     * others pushed (farthest first), else the top of the stack. */
    int order[TR_BVH_MAX_WIDTH];
    int n_inner = tr_inner_order(inner, t_entry, tmax_grown, !any_hit, order);
    for (int j = n_inner - 1; j > 0; --j) {
      if (top < TR_BVH_STACK_SIZE) {
        int k = order[j];
        stack_node[top] = first[k];
        stack_t[top] = t_entry[k];
        stack_rays[top] = child_rays[k];
        stack_lead[top] = child_lead[k];
        ++top;
      }
    }
    int next = -1;
    tr_mask64 next_rays = 0;
    if (n_inner > 0) {
      next_rays = child_rays[order[0]] & live;
      next = next_rays != 0 ? first[order[0]] : -1;
      lead = child_lead[order[0]];
    }
    while (next < 0 && top > 0) {
      --top;
      next_rays = stack_rays[top] & live;
      if (next_rays != 0 && stack_t[top] <= tmax_grown) {
        next = stack_node[top];
        lead = stack_lead[top];
      }
    }
    if (next < 0) break;
    /* Any hit: a blocked lead is replaced by a ray still live (which may not enter
     * the node: the lead only saves tests, and a wrong guess costs some). */
    if (!((next_rays >> lead) & 1u)) lead = TR_LOWEST_BIT64(next_rays);
    index = next;
    node_rays = next_rays;
  }
}

/* The walks a packet's rays fall back on, one by one; out of line, so that the code
 * holds one copy of each besides the ray queries' own (scene_hit.h). */
TR_FN_NOINLINE void tr_bvh_nearest(const TrSceneRef* s, const TrRay* ray, TrNearest* nearest) {
  tr_bvh_walk(s, *ray, nearest, 0);
}

TR_FN_NOINLINE int tr_bvh_blocked(const TrSceneRef* s, const TrRay* ray, real tmax) {
  TrNearest limit = tr_nearest(tmax, -1);
  return tr_bvh_walk(s, *ray, &limit, 1);
}

/* The BVH part of a packet query (pk->t and pk->prim set, tr_packet_begin's answer in
 * coherent), on an 8-wide tree: a coherent packet takes the masked walk, an incoherent
 * one goes ray by ray. Its rays share few nodes (reflections off curved mirrors: 3.4
 * rays per node visit on spheres_1e6, against 18-20 for mesh_1e6's coherent packets),
 * and walking them as a packet made spheres_1e6 frames 5% slower. Packets walk only
 * the 8-wide trees both backends build for CPUs (bvh::kCpuWidth): each width is a copy
 * of the walk in every instantiation of the device code, and two more widths made a
 * rendering translation unit compile 40% longer. Closest hit: each ray's nearest
 * (t, primitive) in pk->t and pk->prim. Any hit: pk->t[r] < 0 where ray r is blocked. */
TR_FN void tr_packet_bvh(const TrSceneRef* s, TrRayPacket* pk, int coherent, int any_hit) {
  if (coherent && tr_use(s, TR_F_BVH8)) {
    tr_mask64 active = 0;
    for (int r = 0; r < pk->n; ++r) active |= (tr_mask64)(pk->t[r] >= TR_R(0.0)) << r;
    /* A copy of the walk for each kind of query, any_hit a constant in each, so that
     * no node tests it: a few percent on the 1e5 and 1e6 scenes (docs/performance.md). */
    if (any_hit)
      tr_packet_walk_masked(s, pk, active, 1, 8, 0, 0);
    else
      tr_packet_walk_masked(s, pk, active, 0, 8, 0, 0);
    return;
  }
  for (int r = 0; r < pk->n; ++r) {
    if (any_hit) {
      if (pk->t[r] >= TR_R(0.0) && tr_bvh_blocked(s, &pk->ray[r], pk->t[r])) pk->t[r] = TR_R(-1.0);
      continue;
    }
    TrNearest nearest = tr_nearest(pk->t[r], pk->prim[r]);
    tr_bvh_nearest(s, &pk->ray[r], &nearest);
    pk->t[r] = nearest.t;
    pk->prim[r] = nearest.prim;
  }
}
