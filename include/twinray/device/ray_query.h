/* Ray queries on the user's own rays (docs/ray-queries.md): the closest hit
 * (tr_query_intersect) and whether anything is hit (tr_query_occluded) for one
 * TrQueryRay, through the same walk the renderer's rays take (bvh_traverse.h) with the
 * query's interval [tmin, tmax] and mask, or for the CPU backend's batches through the
 * renderer's packet walk where rays run together (tr_query_intersect_rays, below). The
 * CPU backend calls these functions in C++, the query kernels of kernels/render.cl in
 * OpenCL C: the same text, the same bits.
 *
 * The closest hit is the smallest (t, object, primitive) with t > 0 in [tmin, tmax]
 * (tr_query_precedes), so no batch size, ray order, thread count, BVH width, ISA or
 * backend changes it. A ray that is not valid (tr_query_ray_valid) is a miss, and is
 * never occluded. */

/* Whether x is finite (neither infinite nor NaN). */
TR_FN_INLINE int tr_query_finite(real x) {
  return tr_fabs(x) < TR_R(INFINITY);
}

/* A query ray the engine answers: finite origin and direction, a direction other than
 * zero, tmin finite, tmax >= tmin and tmax >= 0 (tmax may be +inf; a NaN fails). Any
 * other ray gets a miss. */
TR_FN_INLINE int tr_query_ray_valid(TR_GLOBAL const TrQueryRay* r) {
  int finite = tr_query_finite(r->ox) & tr_query_finite(r->oy) & tr_query_finite(r->oz) &
               tr_query_finite(r->dx) & tr_query_finite(r->dy) & tr_query_finite(r->dz) &
               tr_query_finite(r->tmin);
  int nonzero = (r->dx != TR_R(0.0)) | (r->dy != TR_R(0.0)) | (r->dz != TR_R(0.0));
  return finite & nonzero & (r->tmax >= r->tmin) & (r->tmax >= TR_R(0.0));
}

/* Offers (t, prim) to a query's nearest hit (tr_query_precedes), with a triangle's
 * barycentrics bary (kept in uv as tr_bvh_walk_query keeps them); 1 where an any-hit
 * query is answered by it. */
TR_FN_INLINE int tr_query_take(const TrSceneRef* s, TrNearest* nearest, real* uv, real t, int prim,
                               real tmin, int any_hit, vec3 bary) {
  if (!tr_query_precedes_in(s, t, -1, prim, tmin, nearest->t, nearest->instance, nearest->prim))
    return 0;
  *nearest = tr_nearest(t, prim);
  uv[0] = bary.y;
  uv[1] = bary.z;
  return any_hit;
}

/* The planes (outside the BVH) offered to a query's nearest hit: closest hit, *nearest
 * updated; any hit, returns 1 at the first plane hit. */
TR_FN_INLINE int tr_query_planes(const TrSceneRef* s, TrRay ray, real tmin, unsigned int mask,
                                 TrNearest* nearest, real* uv, int any_hit) {
  if (TR_HAS(TR_F_PLANES)) {
    int n_bounded = s->params->n_spheres + s->params->n_triangles;
    vec3 none = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    for (int i = 0; i < s->params->n_planes; ++i)
      if (!tr_query_skips(s, n_bounded + i, mask) &&
          tr_query_take(s, nearest, uv, tr_plane_t(&s->planes[i], ray), n_bounded + i, tmin,
                        any_hit, none))
        return 1;
  }
  return 0;
}

/* The query's search over the whole scene, nearest->t holding tmax and nearest->prim
 * -1 at the start: the BVH (or the flat arrays of a scene without one), then the
 * planes. Closest hit: *nearest is the hit, and the result whether there is one. Any
 * hit: returns 1 at the first hit. */
TR_FN_INLINE int tr_query_search(const TrSceneRef* s, TrRay ray, real tmin, unsigned int mask,
                                 TrNearest* nearest, real* uv, int any_hit) {
  int n_spheres = s->params->n_spheres;
  int n_bounded = n_spheres + s->params->n_triangles;
  if (tr_use(s, TR_F_BVH)) {
    if (tr_bvh_walk_query(s, ray, nearest, any_hit, tmin, mask, uv) && any_hit) return 1;
  } else {
    vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < n_spheres; ++i)
        if (!tr_query_skips(s, i, mask) &&
            tr_query_take(s, nearest, uv, tr_sphere_t_from(&s->spheres[i], ray, tmin), i, tmin,
                          any_hit, bary))
          return 1;
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = n_spheres; i < n_bounded; ++i) {
        if (tr_query_skips(s, i, mask)) continue;
        real t = tr_triangle_t_bary(&s->triangles[i - n_spheres], ray, &tri_ray, &bary);
        if (tr_query_take(s, nearest, uv, t, i, tmin, any_hit, bary)) return 1;
      }
    }
  }
  if (tr_query_planes(s, ray, tmin, mask, nearest, uv, any_hit)) return 1;
  return nearest->prim >= 0;
}

/* The engine's ray for a query ray: its origin and direction as given (t counts
 * lengths of the direction, as in Embree). */
TR_FN_INLINE TrRay tr_query_ray(TR_GLOBAL const TrQueryRay* r) {
  TrRay ray;
  ray.o = TR_VEC3(r->ox, r->oy, r->oz);
  ray.d = TR_VEC3(r->dx, r->dy, r->dz);
  return ray;
}

/* The surface parameters (u, v) of the nearest hit, whose record is *hit:
 *  - triangle: the barycentric coordinates of vertices 1 and 2 (the hit point is
 *    (1 - u - v) p0 + u p1 + v p2), kept from the watertight test that found it
 *    (uv[0], uv[1]);
 *  - sphere: the octahedral map of the outward unit normal n onto [0, 1]^2 (Cigolle et
 *    al., "A Survey of Efficient Representations for Independent Unit Vectors", JCGT
 *    3(2), 2014): (x, y) = (n.x, n.y) / |n|_1, folded over the diagonals where n.z < 0,
 *    then u = x/2 + 1/2, v = y/2 + 1/2; a bijection, in + - * / only (no atan2);
 *  - plane: the hit point's coordinates from the plane's point along the tangents b1,
 *    b2 of Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017,
 *    made from its unit normal. */
TR_FN void tr_query_surface_uv(const TrSceneRef* s, TrNearest nearest, const real* uv,
                               const TrHit* hit, real* u, real* v) {
  int n_spheres = s->params->n_spheres, n_bounded = n_spheres + s->params->n_triangles;
  int prim = nearest.prim;
  *u = TR_R(0.0);
  *v = TR_R(0.0);
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres) {
    vec3 n = hit->n;
    real l1 = tr_fabs(n.x) + tr_fabs(n.y) + tr_fabs(n.z);
    real x = n.x / l1, y = n.y / l1;
    if (n.z < TR_R(0.0)) {
      real fx = (TR_R(1.0) - tr_fabs(y)) * (x >= TR_R(0.0) ? TR_R(1.0) : TR_R(-1.0));
      real fy = (TR_R(1.0) - tr_fabs(x)) * (y >= TR_R(0.0) ? TR_R(1.0) : TR_R(-1.0));
      x = fx;
      y = fy;
    }
    *u = x * TR_R(0.5) + TR_R(0.5);
    *v = y * TR_R(0.5) + TR_R(0.5);
  } else if (TR_HAS(TR_F_TRIANGLES) && prim < n_bounded) {
    *u = uv[0];
    *v = uv[1];
  } else if (TR_HAS(TR_F_PLANES)) {
    TR_GLOBAL const TrPlane* pl = &s->planes[prim - n_bounded];
    vec3 n = tr_plane_normal(pl);
    real sign = n.z >= TR_R(0.0) ? TR_R(1.0) : TR_R(-1.0);
    real a = TR_R(-1.0) / (sign + n.z);
    real b = n.x * n.y * a;
    vec3 b1 = TR_VEC3(TR_R(1.0) + sign * n.x * n.x * a, sign * b, -sign * n.x);
    vec3 b2 = TR_VEC3(b, sign + n.y * n.y * a, -n.y);
    vec3 rel = hit->p - tr_plane_point(pl);
    *u = tr_dot(rel, b1);
    *v = tr_dot(rel, b2);
  }
}

/* The answer of a closest-hit query into *out (TrQueryHit) and, where extra_flags asks
 * (TR_QUERY_*), the extras into *extras (fields not asked for are 0): the hit of ray
 * `ray` at nearest where `found`, else a miss. */
TR_FN void tr_query_write(const TrSceneRef* s, TrRay ray, TrNearest nearest, const real* uv,
                          int found, TR_GLOBAL TrQueryHit* out, TR_GLOBAL TrQueryExtras* extras,
                          int extra_flags) {
  TrQueryHit h;
  h.t = TR_R(INFINITY);
  h.u = TR_R(0.0);
  h.v = TR_R(0.0);
  h.nx = TR_R(0.0);
  h.ny = TR_R(0.0);
  h.nz = TR_R(0.0);
  h.object = -1;
  h.primitive = -1;
  h.instance = -1;
  h.pad0 = 0;
  TrQueryExtras e;
  e.snx = TR_R(0.0);
  e.sny = TR_R(0.0);
  e.snz = TR_R(0.0);
  e.tex_u = TR_R(0.0);
  e.tex_v = TR_R(0.0);
  e.pad0 = TR_R(0.0);
  if (found) {
    /* A hit in an instance is recorded, and its surface parameters taken, in the
     * asset's space; then the record comes to the world (instance.h). */
    int in_instance = TR_HAS(TR_F_INSTANCES) && nearest.instance >= 0;
    TrRay asset_ray = in_instance ? tr_instance_ray(&s->instances[nearest.instance], ray) : ray;
    TrNearest asset_nearest = nearest;
    asset_nearest.instance = -1;
    int triangle = nearest.prim - s->params->n_spheres;
    vec3 n, ns = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    real tex_u = TR_R(0.0), tex_v = TR_R(0.0);
    int object; /* in an instance: the object's index in its asset */
    if (extra_flags == 0 && TR_HAS(TR_F_TRIANGLES) && triangle >= 0 &&
        triangle < s->params->n_triangles) {
      /* A triangle with no extras asked: its (u, v) and normal, the same values the
       * full record (tr_triangle_record) holds, without the rest of the record. */
      TR_GLOBAL const TrTriangle* tri = &s->triangles[triangle];
      h.u = uv[0];
      h.v = uv[1];
      n = tr_triangle_unit_normal(tri);
      object = tri->object;
      if (in_instance) n = tr_instance_normal(&s->instances[nearest.instance], n);
    } else {
      TrHit hit;
      tr_record_hit(s, asset_ray, asset_nearest, &hit);
      tr_query_surface_uv(s, asset_nearest, uv, &hit, &h.u, &h.v);
      object = hit.object;
      if (in_instance) tr_instance_hit_to_world(&s->instances[nearest.instance], &hit);
      n = hit.n;
      ns = hit.ns;
      tex_u = hit.u;
      tex_v = hit.v;
    }
    if (in_instance) h.instance = s->instances[nearest.instance].object;
    /* The normal faces the side the ray comes from. */
    int flip = tr_dot(n, ray.d) > TR_R(0.0);
    n = flip ? -n : n;
    h.t = nearest.t;
    h.nx = n.x;
    h.ny = n.y;
    h.nz = n.z;
    h.object = object;
    h.primitive = tr_query_face(s, nearest.prim);
    if ((extra_flags & TR_QUERY_SHADING_NORMAL) != 0) {
      ns = flip ? -ns : ns;
      e.snx = ns.x;
      e.sny = ns.y;
      e.snz = ns.z;
    }
    if ((extra_flags & TR_QUERY_TEXTURE_UV) != 0) {
      e.tex_u = tex_u;
      e.tex_v = tex_v;
    }
  }
  *out = h;
  if (extra_flags != 0) *extras = e;
}

/* The closest hit of *in into *out (TrQueryHit; a miss where there is none or the ray
 * is not valid), and where extra_flags asks (TR_QUERY_*), the extras into *extras
 * (fields not asked for are 0). */
TR_FN void tr_query_intersect(const TrSceneRef* s, TR_GLOBAL const TrQueryRay* in,
                              TR_GLOBAL TrQueryHit* out, TR_GLOBAL TrQueryExtras* extras,
                              int extra_flags) {
  TrRay ray = tr_query_ray(in);
  TrNearest nearest = tr_nearest(in->tmax, -1);
  real uv[2] = {TR_R(0.0), TR_R(0.0)};
  int found =
      tr_query_ray_valid(in) && tr_query_search(s, ray, in->tmin, in->mask, &nearest, uv, 0);
  tr_query_write(s, ray, nearest, uv, found, out, extras, extra_flags);
}

/* Whether anything lies on *in within [tmin, tmax] (t > 0): exactly when
 * tr_query_intersect finds a hit. 0 for a ray that is not valid. */
TR_FN int tr_query_occluded(const TrSceneRef* s, TR_GLOBAL const TrQueryRay* in) {
  if (!tr_query_ray_valid(in)) return 0;
  TrNearest limit = tr_nearest(in->tmax, -1);
  real uv[2];
  return tr_query_search(s, tr_query_ray(in), in->tmin, in->mask, &limit, uv, 1);
}

/* Ray queries in packets (the CPU backend; the OpenCL kernels answer a ray per
 * work-item). A batch is taken in runs of TR_QUERY_RUN rays, whose valid rays with no
 * zero component of direction are walked TR_PACKET_MAX at a time through the
 * renderer's packet walk (bvh_packet.h, tr_packet_walk_masked) where their directions
 * share their signs (tr_packet_begin); the others go alone, through tr_query_intersect
 * or tr_query_occluded. Packets are made of consecutive rays; in a run where most rays
 * start where the ray before them does (several rays from each point, as ambient
 * occlusion casts them), of the rays of one octant of direction (the signs of its
 * components) in the batch's order instead: rays from a few points in one octant share
 * much of their walks, where rays from points spread apart (one diffuse ray per hit)
 * walked 1.5-2.7 times as long in such packets as one by one
 * (bench/ray_query_bench.cpp). The packet walk offers each ray exactly the leaves its
 * own box test enters, and its leaves take hits by the query's own rule
 * (tr_packet_query_offer, tr_packet_query_tie, and for lone rays tr_query_precedes);
 * since that rule is a total order on (t, object, primitive) and the nearest hit's leaf
 * is entered on any walk, each ray gets the answer of tr_query_intersect and
 * tr_query_occluded, bit for bit, whichever rays share its packet. Only on 8-wide
 * trees, the width the packet walk is compiled for (tr_packet_bvh). */

/* The octant of a query ray's direction (bit 0: dx < 0, bit 1: dy < 0, bit 2: dz < 0),
 * or -1 where the ray is not valid or a component of its direction is 0 (such a ray
 * goes alone). */
TR_FN_INLINE int tr_query_octant(TR_GLOBAL const TrQueryRay* r) {
  if (!tr_query_ray_valid(r) || r->dx == TR_R(0.0) || r->dy == TR_R(0.0) || r->dz == TR_R(0.0))
    return -1;
  return (r->dx < TR_R(0.0) ? 1 : 0) | (r->dy < TR_R(0.0) ? 2 : 0) | (r->dz < TR_R(0.0) ? 4 : 0);
}

/* Puts the rays of in[0 .. m), m <= TR_QUERY_RUN, that have an octant into qp->order,
 * in groups qp->order[qp->group_start[k] .. qp->group_start[k + 1]) for k < 8, each
 * in the batch's order; qp->octant[i] is ray i's octant (-1: alone). The groups are the
 * octants (a counting sort) where `by_octant` is 1, or where it is 2 and more than
 * half of the rays start where the ray before them does; else group 0 holds them all.
 * With by_octant -1 every ray goes alone. */
TR_FN void tr_query_group_run(TrQueryPacket* qp, TR_GLOBAL const TrQueryRay* in, int m,
                              int by_octant) {
  if (by_octant < 0) {
    for (int i = 0; i < m; ++i) qp->octant[i] = -1;
    for (int k = 0; k <= 8; ++k) qp->group_start[k] = 0;
    return;
  }
  int count[8];
  for (int k = 0; k < 8; ++k) count[k] = 0;
  int shared = 0;
  for (int i = 0; i < m; ++i) {
    int o = tr_query_octant(&in[i]);
    qp->octant[i] = o;
    if (o >= 0) ++count[o];
    if (i > 0)
      shared +=
          (in[i].ox == in[i - 1].ox) & (in[i].oy == in[i - 1].oy) & (in[i].oz == in[i - 1].oz);
  }
  int sort = by_octant == 1 || (by_octant == 2 && 2 * shared > m);
  if (!sort) {
    for (int k = 1; k < 8; ++k) {
      count[0] += count[k];
      count[k] = 0;
    }
  }
  qp->group_start[0] = 0;
  for (int k = 0; k < 8; ++k) qp->group_start[k + 1] = qp->group_start[k] + count[k];
  int next[8];
  for (int k = 0; k < 8; ++k) next[k] = qp->group_start[k];
  for (int i = 0; i < m; ++i)
    if (qp->octant[i] >= 0) qp->order[next[sort ? qp->octant[i] : 0]++] = i;
}

/* Loads the rays in[pick[0 .. n)], n <= TR_PACKET_MAX, all valid, into the packet:
 * ray, tmax (the nearest hit so far), tmin, mask and index in `in`, and returns n,
 * where they all have one octant (qp->octant); else marks each of them to go alone
 * (octant -1) and returns 0. */
TR_FN int tr_query_packet_load(TrQueryPacket* qp, TR_GLOBAL const TrQueryRay* in, const int* pick,
                               int n) {
  TrRayPacket* pk = &qp->packet;
  int same = 1;
  for (int k = 1; k < n; ++k) same &= qp->octant[pick[k]] == qp->octant[pick[0]];
  if (!same) {
    for (int k = 0; k < n; ++k) qp->octant[pick[k]] = -1;
    n = 0;
  }
  for (int k = 0; k < n; ++k) {
    TR_GLOBAL const TrQueryRay* r = &in[pick[k]];
    pk->ray[k] = tr_query_ray(r);
    pk->t[k] = r->tmax;
    pk->prim[k] = -1;
    qp->lanes.tmin[k] = r->tmin;
    qp->lanes.mask[k] = r->mask;
    pk->u[k] = TR_R(0.0);
    pk->v[k] = TR_R(0.0);
    qp->index[k] = pick[k];
  }
  pk->n = n;
  return n;
}

/* Whether the directions of the rays in[pick[0 .. n)] lie close enough together for one
 * walk to pay: each direction scaled to unit L1 length, no component spans more than
 * 1/4 across them. Rays of one octant that fan out (ambient occlusion's hemisphere from
 * a few points, diffuse bounces) walked 1.1-1.25 times as long as packets as one by
 * one, where a 1080p camera's neighbouring rays, far narrower, walked 0.5-0.65 times as
 * long (bench/ray_query_bench.cpp). Tested before the rays are loaded, and left at the
 * first ray that widens a span past the limit: fanned rays go alone at little more than
 * the cost of their grouping. The choice changes no answer. */
TR_FN_INLINE int tr_query_rays_narrow(TR_GLOBAL const TrQueryRay* in, const int* pick, int n) {
  real lo_x = TR_R(1.0), lo_y = TR_R(1.0), lo_z = TR_R(1.0);
  real hi_x = TR_R(-1.0), hi_y = TR_R(-1.0), hi_z = TR_R(-1.0);
  real limit = TR_R(0.25);
  for (int k = 0; k < n; ++k) {
    TR_GLOBAL const TrQueryRay* r = &in[pick[k]];
    real scale = TR_R(1.0) / (tr_fabs(r->dx) + tr_fabs(r->dy) + tr_fabs(r->dz));
    real x = r->dx * scale, y = r->dy * scale, z = r->dz * scale;
    lo_x = x < lo_x ? x : lo_x;
    lo_y = y < lo_y ? y : lo_y;
    lo_z = z < lo_z ? z : lo_z;
    hi_x = x > hi_x ? x : hi_x;
    hi_y = y > hi_y ? y : hi_y;
    hi_z = z > hi_z ? z : hi_z;
    if (!((hi_x - lo_x <= limit) & (hi_y - lo_y <= limit) & (hi_z - lo_z <= limit))) return 0;
  }
  return 1;
}

/* Whether the rays in[0 .. m) fan out: at most half of 16 pairs of neighbouring rays
 * (i - 1, i), spread evenly over the run (every pair of a shorter one), are narrow as
 * tr_query_rays_narrow has it. The hemispheres of ambient occlusion and diffuse bounces
 * fan out; a camera's or a LiDAR's neighbouring rays do not. The default walk sends a
 * fanned run's rays alone without grouping them: tr_query_rays_narrow would turn their
 * packets down one by one, and the grouping cost 12-20% of a lone ray's walk on
 * mesh_1e6's ambient occlusion, one thread. A single ray goes alone. */
TR_FN_INLINE int tr_query_run_fanned(TR_GLOBAL const TrQueryRay* in, int m) {
  int pairs = m - 1 < 16 ? m - 1 : 16, close = 0;
  for (int k = 1; k <= pairs; ++k) {
    int i = k * (m - 1) / pairs; /* the pairs (i - 1, i), evenly over the run */
    int pick[2];
    pick[0] = i - 1;
    pick[1] = i;
    close += tr_query_rays_narrow(in, pick, 2);
  }
  return 2 * close <= pairs;
}

/* The BVH part of the loaded packet's queries: closest hit, each ray's nearest (t,
 * primitive) in pk->t and pk->prim; any hit, pk->t[r] < 0 where ray r is blocked. As
 * one packet where the rays are coherent (returns 1; rays of one octant are, but for an
 * infinite reciprocal of a tiny component), else ray by ray (tr_bvh_walk_query, as
 * tr_query_search walks it). */
TR_FN_INLINE int tr_query_packet_bvh(const TrSceneRef* s, TrQueryPacket* qp, int any_hit) {
  TrRayPacket* pk = &qp->packet;
  if (pk->n <= 0) return 0;
  if (tr_packet_begin(pk)) {
    tr_mask64 active = pk->n >= 64 ? ~(tr_mask64)0 : ((tr_mask64)1 << pk->n) - 1;
    tr_packet_walk_masked(s, pk, active, any_hit, 8, 1, &qp->lanes);
    return 1;
  }
  for (int r = 0; r < pk->n; ++r) {
    TrNearest nearest = tr_nearest(pk->t[r], pk->prim[r]);
    real uv[2] = {pk->u[r], pk->v[r]};
    int blocked = tr_bvh_walk_query(s, pk->ray[r], &nearest, any_hit, qp->lanes.tmin[r],
                                    qp->lanes.mask[r], uv) &&
                  any_hit;
    pk->t[r] = blocked ? TR_R(-1.0) : nearest.t;
    pk->prim[r] = nearest.prim;
    pk->u[r] = uv[0];
    pk->v[r] = uv[1];
  }
  return 0;
}

/* The answers of the rays in[0 .. n), in packets where the scene has an 8-wide BVH,
 * grouped as tr_query_group_run groups them: closest hits into out[i] (and where
 * extra_flags asks, extras[i]) as tr_query_intersect gives them, or with any_hit 1 (a
 * constant) blocked[i] as tr_query_occluded does. Returns how many rays went through
 * the packet walk. */
TR_FN_INLINE int tr_query_rays(const TrSceneRef* s, TrQueryPacket* qp,
                               TR_GLOBAL const TrQueryRay* in, int n, TR_GLOBAL TrQueryHit* out,
                               TR_GLOBAL TrQueryExtras* extras, int extra_flags,
                               TR_GLOBAL unsigned char* blocked, int any_hit, int by_octant) {
  int walked = 0;
  TrRayPacket* pk = &qp->packet;
  for (int at = 0; at < n; at += TR_QUERY_RUN) {
    int m = n - at < TR_QUERY_RUN ? n - at : TR_QUERY_RUN;
    TR_GLOBAL const TrQueryRay* run = in + at;
    /* Instances are walked ray by ray, and so are the rays of a run that fans out
     * where the walk is left to choose. */
    int grouping = tr_use(s, TR_F_BVH8) && !tr_use(s, TR_F_INSTANCES) ? by_octant : -1;
    if (grouping == 2 && tr_query_run_fanned(run, m)) grouping = -1;
    tr_query_group_run(qp, run, m, grouping);
    for (int k = 0; k < 8; ++k)
      for (int j = qp->group_start[k]; j < qp->group_start[k + 1]; j += TR_PACKET_MAX) {
        int end = qp->group_start[k + 1];
        const int* pick = &qp->order[j];
        int n_pick = end - j < TR_PACKET_MAX ? end - j : TR_PACKET_MAX;
        if (by_octant == 2 && !tr_query_rays_narrow(run, pick, n_pick)) {
          for (int r = 0; r < n_pick; ++r) qp->octant[pick[r]] = -1; /* they go alone */
          continue;
        }
        tr_query_packet_load(qp, run, pick, n_pick);
        if (tr_query_packet_bvh(s, qp, any_hit)) walked += pk->n;
        for (int r = 0; r < pk->n; ++r) {
          int i = at + qp->index[r];
          TrNearest nearest = tr_nearest(pk->t[r], any_hit ? -1 : pk->prim[r]);
          real uv[2] = {pk->u[r], pk->v[r]};
          int b = (any_hit && pk->t[r] < TR_R(0.0)) ||
                  tr_query_planes(s, pk->ray[r], qp->lanes.tmin[r], qp->lanes.mask[r], &nearest, uv,
                                  any_hit);
          if (any_hit)
            blocked[i] = (unsigned char)(b ? 1 : 0);
          else
            tr_query_write(s, pk->ray[r], nearest, uv, nearest.prim >= 0, &out[i],
                           extra_flags != 0 ? &extras[i] : extras, extra_flags);
        }
      }
    for (int i = 0; i < m; ++i) {
      if (qp->octant[i] >= 0) continue;
      if (any_hit)
        blocked[at + i] = (unsigned char)(tr_query_occluded(s, &run[i]) ? 1 : 0);
      else
        tr_query_intersect(s, &run[i], &out[at + i], extra_flags != 0 ? &extras[at + i] : extras,
                           extra_flags);
    }
  }
  return walked;
}

/* tr_query_intersect for each of the rays in[0 .. n), in packets (tr_query_rays; by_octant:
 * 0 never by octant, 1 always, 2 where rays share their origins, and then only packets
 * whose directions are narrow, tr_query_rays_narrow). */
TR_FN int tr_query_intersect_rays(const TrSceneRef* s, TrQueryPacket* qp,
                                  TR_GLOBAL const TrQueryRay* in, int n, TR_GLOBAL TrQueryHit* out,
                                  TR_GLOBAL TrQueryExtras* extras, int extra_flags, int by_octant) {
  return tr_query_rays(s, qp, in, n, out, extras, extra_flags, 0, 0, by_octant);
}

/* tr_query_occluded for each of the rays in[0 .. n) into blocked[i] (1 or 0), in
 * packets as tr_query_intersect_rays. */
TR_FN int tr_query_occluded_rays(const TrSceneRef* s, TrQueryPacket* qp,
                                 TR_GLOBAL const TrQueryRay* in, int n,
                                 TR_GLOBAL unsigned char* blocked, int by_octant) {
  return tr_query_rays(s, qp, in, n, 0, 0, 0, blocked, 1, by_octant);
}
