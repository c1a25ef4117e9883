/* Ray queries on the user's own rays (docs/ray-queries.md): the closest hit
 * (tr_query_intersect) and whether anything is hit (tr_query_occluded) for one
 * TrQueryRay, through the same walk the renderer's rays take (bvh_traverse.h) with the
 * query's interval [tmin, tmax] and mask. The CPU backend calls these functions in
 * C++, the query kernels of kernels/render.cl in OpenCL C: the same text, the same
 * bits.
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

/* Offers (t, prim) to a query's nearest hit (tr_query_precedes); 1 where an any-hit
 * query is answered by it. */
TR_FN_INLINE int tr_query_take(const TrSceneRef* s, TrNearest* nearest, real t, int prim, real tmin,
                               int any_hit) {
  if (!tr_query_precedes(s, t, prim, tmin, nearest->t, nearest->prim)) return 0;
  nearest->t = t;
  nearest->prim = prim;
  return any_hit;
}

/* The query's search over the whole scene, nearest->t holding tmax and nearest->prim
 * -1 at the start: the BVH (or the flat arrays of a scene without one), then the
 * planes. Closest hit: *nearest is the hit, and the result whether there is one. Any
 * hit: returns 1 at the first hit. */
TR_FN_INLINE int tr_query_search(const TrSceneRef* s, TrRay ray, real tmin, unsigned int mask,
                                 TrNearest* nearest, int any_hit) {
  int n_spheres = s->params->n_spheres;
  int n_bounded = n_spheres + s->params->n_triangles;
  if (tr_use(s, TR_F_BVH)) {
    if (tr_bvh_walk_query(s, ray, nearest, any_hit, tmin, mask) && any_hit) return 1;
  } else {
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < n_spheres; ++i)
        if (!tr_query_skips(s, i, mask) &&
            tr_query_take(s, nearest, tr_sphere_t_from(&s->spheres[i], ray, tmin), i, tmin,
                          any_hit))
          return 1;
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = n_spheres; i < n_bounded; ++i)
        if (!tr_query_skips(s, i, mask) &&
            tr_query_take(s, nearest, tr_triangle_t(&s->triangles[i - n_spheres], ray, &tri_ray), i,
                          tmin, any_hit))
          return 1;
    }
  }
  if (TR_HAS(TR_F_PLANES)) {
    for (int i = 0; i < s->params->n_planes; ++i)
      if (!tr_query_skips(s, n_bounded + i, mask) &&
          tr_query_take(s, nearest, tr_plane_t(&s->planes[i], ray), n_bounded + i, tmin, any_hit))
        return 1;
  }
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
 *    (1 - u - v) p0 + u p1 + v p2), from the same watertight test that found it;
 *  - sphere: the octahedral map of the outward unit normal n onto [0, 1]^2 (Cigolle et
 *    al., "A Survey of Efficient Representations for Independent Unit Vectors", JCGT
 *    3(2), 2014): (x, y) = (n.x, n.y) / |n|_1, folded over the diagonals where n.z < 0,
 *    then u = x/2 + 1/2, v = y/2 + 1/2; a bijection, in + - * / only (no atan2);
 *  - plane: the hit point's coordinates from the plane's point along the tangents b1,
 *    b2 of Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 6(1), 2017,
 *    made from its unit normal. */
TR_FN void tr_query_surface_uv(const TrSceneRef* s, TrRay ray, TrNearest nearest, const TrHit* hit,
                               real* u, real* v) {
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
    TrTriangleRay tri_ray = tr_triangle_ray(ray);
    vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    tr_triangle_t_bary(&s->triangles[prim - n_spheres], ray, &tri_ray, &bary);
    *u = bary.y;
    *v = bary.z;
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

/* The closest hit of *in into *out (TrQueryHit; a miss where there is none or the ray
 * is not valid), and where extra_flags asks (TR_QUERY_*), the extras into *extras
 * (fields not asked for are 0). */
TR_FN void tr_query_intersect(const TrSceneRef* s, TR_GLOBAL const TrQueryRay* in,
                              TR_GLOBAL TrQueryHit* out, TR_GLOBAL TrQueryExtras* extras,
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
  TrQueryExtras e;
  e.snx = TR_R(0.0);
  e.sny = TR_R(0.0);
  e.snz = TR_R(0.0);
  e.tex_u = TR_R(0.0);
  e.tex_v = TR_R(0.0);
  e.pad0 = TR_R(0.0);
  if (tr_query_ray_valid(in)) {
    TrRay ray = tr_query_ray(in);
    TrNearest nearest;
    nearest.t = in->tmax;
    nearest.prim = -1;
    if (tr_query_search(s, ray, in->tmin, in->mask, &nearest, 0)) {
      TrHit hit;
      tr_record_hit(s, ray, nearest, &hit);
      /* The normal faces the side the ray comes from. */
      int flip = tr_dot(hit.n, ray.d) > TR_R(0.0);
      vec3 n = flip ? -hit.n : hit.n;
      h.t = nearest.t;
      h.nx = n.x;
      h.ny = n.y;
      h.nz = n.z;
      h.object = hit.object;
      h.primitive = tr_query_face(s, nearest.prim);
      tr_query_surface_uv(s, ray, nearest, &hit, &h.u, &h.v);
      if ((extra_flags & TR_QUERY_SHADING_NORMAL) != 0) {
        vec3 ns = flip ? -hit.ns : hit.ns;
        e.snx = ns.x;
        e.sny = ns.y;
        e.snz = ns.z;
      }
      if ((extra_flags & TR_QUERY_TEXTURE_UV) != 0) {
        e.tex_u = hit.u;
        e.tex_v = hit.v;
      }
    }
  }
  *out = h;
  if (extra_flags != 0) *extras = e;
}

/* Whether anything lies on *in within [tmin, tmax] (t > 0): exactly when
 * tr_query_intersect finds a hit. 0 for a ray that is not valid. */
TR_FN int tr_query_occluded(const TrSceneRef* s, TR_GLOBAL const TrQueryRay* in) {
  if (!tr_query_ray_valid(in)) return 0;
  TrNearest limit;
  limit.t = in->tmax;
  limit.prim = -1;
  return tr_query_search(s, tr_query_ray(in), in->tmin, in->mask, &limit, 1);
}
