/* Closest hits of a packet of coherent rays (up to TR_PACKET_MAX: one block of camera
 * rays) in one walk of the W-wide BVH, with interval culling: the large-packet
 * traversal of Wald, Boulos and Shirley, "Ray Tracing Deformable Scenes Using Dynamic
 * Bounding Volume Hierarchies" (ACM TOG 26(1), 2007), and Overbeck, Ramamoorthi and
 * Mark, "Large Ray Packets for Real-Time Whitted Ray Tracing" (IRT 2008).
 *
 * An inner node's W boxes are tested once for the whole packet, against the interval
 * that holds every ray's origin and reciprocal direction (all rays' directions have the
 * same sign on each axis, or the packet is walked ray by ray). The interval test is
 * conservative against each ray's own box test in floating point, not only in real
 * numbers: rounding is monotonic, so fl(B - o) lies between fl(B - o_hi) and
 * fl(B - o_lo), and fl(x y) between the least and greatest of the rounded products of
 * the bounds. If no ray's own test (tr_ray_hits_boxes) could enter a box, the
 * packet's does not either; the packet may enter more, never fewer. At a leaf each ray
 * takes its own box test, the very operations of tr_ray_hits_boxes, one ray per SIMD
 * lane, and tests the primitives only if it passes (where enough rays pass, a leaf's
 * primitives are tested for every ray, a ray per lane, and kept where it passed). Each
 * ray thus
 * offers its primitives to its own nearest hit (tr_offer_hit), a superset of those its single-ray
 * walk offers that still holds the winner: the image is the same bits as the single-ray walk's
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
  for (int r = 0; r < n; ++r) {
    TrRay ray = pk->ray[r];
    pk->ox[r] = ray.o.x;
    pk->oy[r] = ray.o.y;
    pk->oz[r] = ray.o.z;
    pk->dx[r] = ray.d.x;
    pk->dy[r] = ray.d.y;
    pk->dz[r] = ray.d.z;
  }
  vec3 d0 = TR_VEC3(pk->dx[0], pk->dy[0], pk->dz[0]);
  real grow = tr_box_grow();
  int incoherent = 0;
  if (TR_HAS(TR_F_TRIANGLES)) {
    TR_SIMD_LOOP
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
  TR_SIMD_LOOP
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
    int coherent = (dx * d0.x > TR_R(0.0)) & (dy * d0.y > TR_R(0.0)) & (dz * d0.z > TR_R(0.0)) &
                   (fabs(fx) < TR_R(INFINITY)) & (fabs(fy) < TR_R(INFINITY)) &
                   (fabs(fz) < TR_R(INFINITY));
    incoherent |= !coherent;
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
 * t_entry[k] a lower bound on where any of them enters it. */
TR_FN_INLINE unsigned tr_packet_hits_boxes(TR_GLOBAL const real* boxes, const TrRayPacket* pk,
                                           real tmax_grown, int W, real* t_entry) {
  TrBoxPlanes p = tr_box_planes(boxes, pk->rows, W);
  vec3 o_lo = pk->o_lo, o_hi = pk->o_hi, i_lo = pk->i_lo, i_hi = pk->i_hi;
  vec3 f_lo = pk->f_lo, f_hi = pk->f_hi;
  unsigned mask = 0u;
  TR_SIMD_LOOP
  for (int k = 0; k < W; ++k) {
    real nx = tr_interval_mul_lo(p.near_x[k] - o_hi.x, p.near_x[k] - o_lo.x, i_lo.x, i_hi.x);
    real ny = tr_interval_mul_lo(p.near_y[k] - o_hi.y, p.near_y[k] - o_lo.y, i_lo.y, i_hi.y);
    real nz = tr_interval_mul_lo(p.near_z[k] - o_hi.z, p.near_z[k] - o_lo.z, i_lo.z, i_hi.z);
    real fx = tr_interval_mul_hi(p.far_x[k] - o_hi.x, p.far_x[k] - o_lo.x, f_lo.x, f_hi.x);
    real fy = tr_interval_mul_hi(p.far_y[k] - o_hi.y, p.far_y[k] - o_lo.y, f_lo.y, f_hi.y);
    real fz = tr_interval_mul_hi(p.far_z[k] - o_hi.z, p.far_z[k] - o_lo.z, f_lo.z, f_hi.z);
    mask |= (unsigned)tr_slab_enters(nx, ny, nz, fx, fy, fz, tmax_grown, &t_entry[k]) << k;
  }
  return mask;
}

/* Whether a leaf that `entered` rays of a packet of n entered is tested a ray per SIMD
 * lane for the whole packet (tr_packet_leaf) rather than ray by ray: once a quarter of
 * the packet entered it (a half, an eighth and always measured alike:
 * docs/performance.md). */
TR_FN_INLINE int tr_packet_leaf_in_lanes(int entered, int n) {
  return entered * 4 >= n;
}

/* Each ray's own test of child k's box: tr_ray_hits_boxes's operations, in the same
 * order, with the ray in lane r. Sets enter[r] for the rays that enter and returns how
 * many; lists them in rays[] (in order) only where the leaf goes ray by ray
 * (tr_packet_leaf_in_lanes), the one use of the list. */
TR_FN_INLINE int tr_packet_rays_enter_box(TR_GLOBAL const real* boxes, const TrRayPacket* pk, int W,
                                          int k, int* enter, int* rays) {
  TrBoxPlanes p = tr_box_planes(boxes, pk->rows, W);
  real bnx = p.near_x[k], bny = p.near_y[k], bnz = p.near_z[k];
  real bfx = p.far_x[k], bfy = p.far_y[k], bfz = p.far_z[k];
  real grow = tr_box_grow();
  int n = pk->n;
  TR_SIMD_LOOP
  for (int r = 0; r < n; ++r) {
    real nx = (bnx - pk->ox[r]) * pk->ix[r];
    real ny = (bny - pk->oy[r]) * pk->iy[r];
    real nz = (bnz - pk->oz[r]) * pk->iz[r];
    real fx = (bfx - pk->ox[r]) * pk->fx[r];
    real fy = (bfy - pk->oy[r]) * pk->fy[r];
    real fz = (bfz - pk->oz[r]) * pk->fz[r];
    real t_entry;
    enter[r] = tr_slab_enters(nx, ny, nz, fx, fy, fz, pk->t[r] * grow, &t_entry);
  }
  int count = 0;
  TR_SIMD_LOOP
  for (int r = 0; r < n; ++r) count += enter[r];
  if (count == 0 || tr_packet_leaf_in_lanes(count, n)) return count;
  count = 0;
  for (int r = 0; r < n; ++r) { /* branch-free compaction */
    rays[count] = r;
    count += enter[r];
  }
  return count;
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

/* Triangle prim offered to each ray r of the packet with enter[r] set, a ray per SIMD
 * lane: tr_triangle_hit_at without branches, then tr_packet_offer. Used where enough of
 * the packet entered the leaf; the rays that did not are computed and dropped. */
TR_FN_INLINE void tr_packet_triangle_lanes(const TrSceneRef* s, TrRayPacket* pk, int prim,
                                           const int* enter, int any_hit) {
  TR_GLOBAL const TrTriangle* tri = &s->triangles[prim - s->params->n_spheres];
  vec3 p0 = tr_triangle_p0(tri), p1 = tr_triangle_p1(tri), p2 = tr_triangle_p2(tri);
  int n = pk->n;
  TR_SIMD_LOOP
  for (int r = 0; r < n; ++r) {
    TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
    vec3 bary;
    real t;
    int hit = enter[r] & tr_triangle_hit_at(p0, p1, p2, TR_VEC3(pk->ox[r], pk->oy[r], pk->oz[r]),
                                            &tri_ray, 0, &t, &bary);
    tr_packet_offer(pk, r, hit, t, prim, any_hit);
  }
}

/* Sphere prim offered to each ray r of the packet with enter[r] set, a ray per SIMD
 * lane, as tr_packet_triangle_lanes does for triangles. */
TR_FN_INLINE void tr_packet_sphere_lanes(const TrSceneRef* s, TrRayPacket* pk, int prim,
                                         const int* enter, int any_hit) {
  TR_GLOBAL const TrSphere* sp = &s->spheres[prim];
  vec3 center = tr_sphere_center(sp);
  real radius = sp->radius;
  int n = pk->n;
  TR_SIMD_LOOP
  for (int r = 0; r < n; ++r) {
    real t;
    int hit = enter[r] & tr_sphere_hit_at(center, radius, tr_packet_ray(pk, r), 0, &t);
    tr_packet_offer(pk, r, hit, t, prim, any_hit);
  }
}

/* A leaf's primitives bvh_prims[first .. first + count) offered to the `entered` rays
 * listed in rays[] (enter[r] set for each of them, clear for the rest of the packet):
 * closest hit or any hit as in tr_packet_offer. A leaf's primitives go a ray per lane
 * where tr_packet_leaf_in_lanes says so (rays[] is then not read), else ray by ray. The
 * lane loops vectorize in g++ and on PoCL alike, since the primitive tests compute in
 * scalars (LLVM does not widen float3). */
TR_FN_INLINE void tr_packet_leaf(const TrSceneRef* s, TrRayPacket* pk, int first, int count,
                                 const int* enter, const int* rays, int entered, int any_hit) {
  int lanes = tr_packet_leaf_in_lanes(entered, pk->n);
  for (int i = first; i < first + count; ++i) {
    int prim = tr_bvh_prim(s, i);
    if (lanes) {
      if (TR_HAS(TR_F_SPHERES) && prim < s->params->n_spheres)
        tr_packet_sphere_lanes(s, pk, prim, enter, any_hit);
      else if (TR_HAS(TR_F_TRIANGLES))
        tr_packet_triangle_lanes(s, pk, prim, enter, any_hit);
      continue;
    }
    /* Ray by ray, the offer keeps its branches: most tests miss, and the selects of
     * tr_packet_offer made spheres_1e5 frames 7% slower here (docs/performance.md). */
    for (int q = 0; q < entered; ++q) {
      int r = rays[q];
      if (any_hit) {
        if (pk->t[r] < TR_R(0.0)) continue; /* blocked by an earlier primitive */
        TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
        real t = tr_primitive_t(s, prim, pk->ray[r], &tri_ray);
        if (t > TR_R(0.0) && t < pk->t[r]) pk->t[r] = TR_R(-1.0);
        continue;
      }
      TrNearest nearest;
      nearest.t = pk->t[r];
      nearest.prim = pk->prim[r];
      TrTriangleRay tri_ray = tr_packet_triangle_ray(pk, r);
      tr_offer_hit(&nearest, tr_primitive_t(s, prim, pk->ray[r], &tri_ray), prim);
      pk->t[r] = nearest.t;
      pk->prim[r] = nearest.prim;
    }
  }
}

/* The greatest of the packet's nearest distances, grown as the box test grows them. */
TR_FN_INLINE real tr_packet_tmax_grown(const TrRayPacket* pk) {
  return tr_lanes_max(pk->t, pk->n) * tr_box_grow();
}

/* Walks the W-wide BVH once for a coherent packet (tr_packet_begin returned 1). Closest
 * hit (any_hit = 0): offers each ray the primitives of the leaves its own box test
 * enters. Any hit: a ray stops at its first primitive in (0, pk->t[r]), which sets
 * pk->t[r] to -1; a negative t fails every box test after that. Inner children are
 * visited as in the ray walk (tr_walk_next: nearest first by the packet's entry bound
 * for closest hits, in bit order for any hits); a popped node is dropped once
 * every ray's nearest hit lies before it, and the walk ends when every ray is done.
 * Returns 1 when done; 0 when the packet stops paying for itself and gives up, after
 * 4 n + 16 nodes, or once 16 leaves have been tested and fewer rays entered them than
 * there were tests: a beam far wider than what its rays cover (shadow rays from a tile
 * of floor near the horizon, kilometres long, over a fine mesh) visited thousands of
 * nodes and made frames ten times slower. What was found stays; the caller walks the
 * rays one by one from there (tr_packet_bvh). */
TR_FN_INLINE int tr_packet_walk_wide(const TrSceneRef* s, TrRayPacket* pk, int any_hit, int W) {
  if (s->params->n_bvh_nodes <= 0) return 1;
  int stack_node[TR_BVH_STACK_SIZE];
  real stack_t[TR_BVH_STACK_SIZE];
  int enter[TR_PACKET_MAX], rays[TR_PACKET_MAX];
  int top = 0;
  int index = 0;
  real tmax_grown = tr_packet_tmax_grown(pk);
  int visits_left = 4 * pk->n + 16;
  int leaf_tests = 0, leaf_entries = 0;
  for (;;) {
    if (--visits_left < 0) return 0;
    TR_GLOBAL const real* boxes = tr_bvh_node(s, index, W);
    TR_GLOBAL const int* first = tr_bvh_node_links(boxes, W);
    TR_GLOBAL const int* count = first + W;
    real t_entry[TR_BVH_MAX_WIDTH];
    unsigned mask = tr_packet_hits_boxes(boxes, pk, tmax_grown, W, t_entry);
    unsigned inner = 0u;
    int leaves_tested = 0;
    while (mask != 0u) {
      int k = TR_LOWEST_BIT(mask);
      mask &= mask - 1u;
      if (count[k] <= 0) {
        inner |= count[k] == 0 ? 1u << k : 0u;
        continue;
      }
      int entered = tr_packet_rays_enter_box(boxes, pk, W, k, enter, rays);
      leaf_tests += 1;
      leaf_entries += entered;
      if (leaf_tests >= 16 && leaf_entries < leaf_tests) return 0;
      if (entered == 0) continue;
      leaves_tested = 1;
      tr_packet_leaf(s, pk, first[k], count[k], enter, rays, entered, any_hit);
    }
    if (leaves_tested) {
      tmax_grown = tr_packet_tmax_grown(pk);
      if (tmax_grown < TR_R(0.0)) break; /* any hit: every ray is blocked */
    }
    int next = tr_walk_next(inner, t_entry, first, tmax_grown, !any_hit, stack_node, stack_t, &top);
    if (next < 0) break;
    index = next;
  }
  return 1;
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

/* Walks the W-wide BVH once for the rays of the packet in `active` (bit r: ray r;
 * tr_packet_begin has run), coherent or not: the masked traversal of ray streams
 * (Wald, Gribble, Boulos, Kensler, "SIMD Ray Stream Tracing", 2007; Fuetterling,
 * Lojewski, Pfreundt, Ebert, "Efficient Ray Tracing Kernels for Modern CPU
 * Architectures", JCGT 4(4), 2015). Each stack entry holds a node and the rays that
 * entered it; at a node each of those rays takes its own box test (tr_ray_hits_planes,
 * with its own nearest hit so far), and child k goes on with the rays that entered it.
 * A ray thus reaches every leaf that can hold its nearest hit (its box test culls only
 * beyond its nearest hit so far, which never falls below the final one) and is
 * offered only primitives of leaves it entered: the answers are tr_bvh_walk's, bit for
 * bit (tr_offer_hit's order; any hit: blocked or not). What the rays share is the
 * node: it is read once for all of them, and the order is chosen once. Inner children
 * go nearest first by the least entry distance among their rays (closest hit), or in
 * bit order (any hit, as tr_walk_next). When the rays share their direction signs
 * (`coherent`: tr_packet_begin's answer, true of every packet tr_packet_bvh walks here),
 * the rows of a node that their box tests read are picked once per node instead of once
 * per ray and node: mesh_1e6 frames took 0.95-0.99 of the time (docs/performance.md).
 * Where a coherent packet's rays spread out over fine geometry (a block's rays over a
 * 1e6-triangle mesh), interval culling (tr_packet_walk_wide) enters leaves none of them
 * enter, while each ray alone waits on memory for every node it reads. */
TR_FN_INLINE void tr_packet_walk_masked(const TrSceneRef* s, TrRayPacket* pk, tr_mask64 active,
                                        int coherent, int any_hit, int W) {
  if (s->params->n_bvh_nodes <= 0) return;
  int stack_node[TR_BVH_STACK_SIZE];
  tr_mask64 stack_rays[TR_BVH_STACK_SIZE];
  int enter[TR_PACKET_MAX], rays[TR_PACKET_MAX];
  for (int r = 0; r < pk->n; ++r) enter[r] = 0;
  real grow = tr_box_grow();
  int top = 0;
  int index = 0;
  tr_mask64 live = active; /* any hit: the rays not blocked yet */
  tr_mask64 node_rays = active;
  for (;;) {
    TR_GLOBAL const real* boxes = tr_bvh_node(s, index, W);
    TR_GLOBAL const int* first = tr_bvh_node_links(boxes, W);
    TR_GLOBAL const int* count = first + W;
    tr_mask64 child_rays[TR_BVH_MAX_WIDTH];
    real child_t[TR_BVH_MAX_WIDTH];
    for (int k = 0; k < W; ++k) {
      child_rays[k] = 0;
      child_t[k] = TR_R(INFINITY);
    }
    unsigned entered_children = 0u;
    TrBoxPlanes planes = tr_box_planes(boxes, pk->rows, W);
    for (tr_mask64 m = node_rays; m != 0; m &= m - 1) {
      int r = TR_LOWEST_BIT64(m);
      TrBoxRay br = tr_packet_box_ray(pk, r);
      if (!coherent) planes = tr_box_planes(boxes, br.rows, W);
      real t_entry[TR_BVH_MAX_WIDTH];
      unsigned hits = tr_ray_hits_planes(&planes, &br, pk->t[r] * grow, W, t_entry);
      entered_children |= hits;
      for (; hits != 0u; hits &= hits - 1u) {
        int k = TR_LOWEST_BIT(hits);
        child_rays[k] |= (tr_mask64)1 << r;
        child_t[k] = t_entry[k] < child_t[k] ? t_entry[k] : child_t[k];
      }
    }
    unsigned inner = 0u;
    int leaves_tested = 0;
    for (unsigned m = entered_children; m != 0u; m &= m - 1u) {
      int k = TR_LOWEST_BIT(m);
      if (count[k] <= 0) {
        inner |= count[k] == 0 ? 1u << k : 0u;
        continue;
      }
      int entered = 0;
      for (tr_mask64 q = child_rays[k]; q != 0; q &= q - 1) rays[entered++] = TR_LOWEST_BIT64(q);
      for (int q = 0; q < entered; ++q) enter[rays[q]] = 1;
      tr_packet_leaf(s, pk, first[k], count[k], enter, rays, entered, any_hit);
      for (int q = 0; q < entered; ++q) enter[rays[q]] = 0;
      leaves_tested = 1;
    }
    if (any_hit && leaves_tested) {
      for (tr_mask64 m = live; m != 0; m &= m - 1) {
        int r = TR_LOWEST_BIT64(m);
        if (pk->t[r] < TR_R(0.0)) live &= ~((tr_mask64)1 << r);
      }
      if (live == 0) break;
    }
    /* The next node: an inner child, the others pushed (nearest first for closest
     * hits: pushed farthest first), else the top of the stack. */
    int next = -1;
    tr_mask64 next_rays = 0;
    int n_inner = 0;
    int order[TR_BVH_MAX_WIDTH];
    for (unsigned m = inner; m != 0u; m &= m - 1u) {
      int k = TR_LOWEST_BIT(m);
      int j = n_inner++;
      if (!any_hit)
        for (; j > 0 && child_t[order[j - 1]] > child_t[k]; --j) order[j] = order[j - 1];
      order[j] = k;
    }
    if (n_inner > 0) {
      for (int j = n_inner - 1; j > 0; --j) {
        if (top < TR_BVH_STACK_SIZE) {
          stack_node[top] = first[order[j]];
          stack_rays[top] = child_rays[order[j]];
          ++top;
        }
      }
      next = first[order[0]];
      next_rays = child_rays[order[0]] & live;
    }
    while (next < 0 && top > 0) {
      --top;
      tr_mask64 popped = stack_rays[top] & live;
      if (popped != 0) {
        next = stack_node[top];
        next_rays = popped;
      }
    }
    if (next < 0) break;
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
  TrNearest limit;
  limit.t = tmax;
  limit.prim = -1;
  return tr_bvh_walk(s, *ray, &limit, 1);
}

/* The most primitives in the BVH for which shadow packets try interval culling
 * (tr_packet_walk_wide) before the masked walk. A block's shadow rays toward a light
 * form a beam from its hits; over denser geometry the beam crosses more small leaves
 * than its rays share. Measured with the masked walk behind it, trying interval culling
 * first there made frames of mesh_1e6 and spheres_1e6 1.06 and 1.08 times as long
 * (before the masked walk, ray by ray against packets: 0.91 and 0.96; about even at
 * 3e5 primitives, packets ahead at 1e5; docs/performance.md). Either way the answers
 * are the same. */
#define TR_SHADOW_PACKET_MAX_PRIMS 524288

/* The BVH part of a packet query (pk->t and pk->prim set, tr_packet_begin's answer in
 * coherent), on an 8-wide tree: a coherent packet walks with interval culling
 * (tr_packet_walk_wide), and where that gives up or is skipped (shadow rays over dense
 * geometry) the masked walk takes its unfinished rays (TR_PACKET_MASKED: on the host,
 * and on OpenCL for large scenes; else they go ray by ray); an incoherent packet goes ray
 * by ray. Its rays share few nodes (reflections off curved mirrors: 3.4 rays per node
 * visit on spheres_1e6, against 18-20 for mesh_1e6's coherent packets), and the masked
 * walk made spheres_1e6 frames 5% slower there. Packets walk only the 8-wide trees
 * both backends build for CPUs (bvh::kCpuWidth): each width is a copy of the walks in
 * every instantiation of the device code, and two more widths made a rendering
 * translation unit compile 40% longer. Closest hit: each ray's nearest (t, primitive)
 * in pk->t and pk->prim. Any hit: pk->t[r] < 0 where ray r is blocked. */
TR_FN void tr_packet_bvh(const TrSceneRef* s, TrRayPacket* pk, int coherent, int any_hit) {
  if (coherent && tr_use(s, TR_F_BVH8)) {
    int dense =
        any_hit && s->params->n_spheres + s->params->n_triangles > TR_SHADOW_PACKET_MAX_PRIMS;
    if (!dense && tr_packet_walk_wide(s, pk, any_hit, 8)) return;
    if (TR_PACKET_MASKED) {
      tr_mask64 active = 0;
      for (int r = 0; r < pk->n; ++r)
        if (pk->t[r] >= TR_R(0.0)) active |= (tr_mask64)1 << r;
      tr_packet_walk_masked(s, pk, active, 1, any_hit, 8);
      return;
    }
  }
  for (int r = 0; r < pk->n; ++r) {
    if (any_hit) {
      if (pk->t[r] >= TR_R(0.0) && tr_bvh_blocked(s, &pk->ray[r], pk->t[r])) pk->t[r] = TR_R(-1.0);
      continue;
    }
    TrNearest nearest;
    nearest.t = pk->t[r];
    nearest.prim = pk->prim[r];
    tr_bvh_nearest(s, &pk->ray[r], &nearest);
    pk->t[r] = nearest.t;
    pk->prim[r] = nearest.prim;
  }
}
