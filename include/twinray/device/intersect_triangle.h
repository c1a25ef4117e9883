/* Watertight ray/triangle intersection (Woop, Benthin, Wald, "Watertight Ray/Triangle
 * Intersection", JCGT 2(1), 2013), in the form of pbrt-v4's IntersectTriangle.
 *
 * The vertices are moved into a ray space where the ray is the +z axis (translate,
 * permute so z is the dominant axis, shear). Each edge function then depends only on
 * its edge's two transformed vertices, so two triangles sharing an edge compute the
 * same value with opposite sign and no ray slips between them. Edge functions that
 * come out exactly 0 count as inside for both neighbours (conservative: a ray through
 * a shared edge may report both, never neither). pbrt's double-precision recompute of
 * zero edge functions is left out: it needs cl_khr_fp64 in float renders, and the
 * conservative test is already watertight. */

TR_FN_INLINE vec3 tr_permute(vec3 v, int kx, int ky, int kz) {
  return TR_VEC3(tr_component(v, kx), tr_component(v, ky), tr_component(v, kz));
}

/* The part of the test that depends on the ray alone (its direction d): which axis
 * becomes z and the shear. Computed once per ray query (scene_hit.h, bvh_traverse.h,
 * for a packet's rays side by side in bvh_packet.h), not per triangle: it holds three
 * of the test's four divisions. Selects only, no branch, so a loop over rays
 * vectorizes. */
TR_FN_INLINE TrTriangleRay tr_triangle_ray_dir(vec3 dir) {
  TrTriangleRay tr;
  vec3 ad = tr_abs3(dir);
  tr.kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
  tr.kx = tr.kz == 2 ? 0 : tr.kz + 1;
  tr.ky = tr.kx == 2 ? 0 : tr.kx + 1;
  vec3 d = tr_permute(dir, tr.kx, tr.ky, tr.kz);
  tr.sx = -d.x / d.z;
  tr.sy = -d.y / d.z;
  tr.sz = TR_R(1.0) / d.z;
  return tr;
}

TR_FN_INLINE TrTriangleRay tr_triangle_ray(TrRay ray) {
  return tr_triangle_ray_dir(ray.d);
}

/* Whether the ray from origin o hits the triangle p0 p1 p2; if so, the distance along
 * it in *t, > 0, and the barycentric coordinates of the hit in *bary.
 * The renderer's walks read only t (the barycentrics are dead code there): its hit
 * record is made once per ray, for the nearest primitive (tr_triangle_record); ray
 * queries keep the nearest hit's barycentrics as they walk (tr_bvh_walk_query). t is
 * not range-tested against the ray's tmax before the division, as Woop et al. do: the
 * caller compares the rounded t itself, so whether a triangle wins never depends on
 * what was found before it (scene_hit.h).
 * With `branches` 1 (one ray) the test returns at its first failed check. With 0 (a
 * constant, in a loop that runs a ray per SIMD lane: bvh_packet.h) it has no control
 * flow: every check is computed, *t and *bary are always set. Both give the same
 * answer, t and barycentrics, from the same operations. No float3 arithmetic (tr_sub3,
 * tr_max_abs), so that PoCL vectorizes that loop too. `may_straddle` 0 (a constant)
 * says the caller knows that the vertices' ray-space depths az, bz, cz are all > 0
 * (tr_packet_hits_boxes's `ahead`), so the straddle bound below, which would then
 * reject nothing, is not computed; 1 otherwise. */
TR_FN_INLINE int tr_triangle_hit_at(vec3 p0, vec3 p1, vec3 p2, vec3 o, const TrTriangleRay* tr,
                                    int branches, int may_straddle, real* t_hit, vec3* bary) {
  /* Translate to the ray origin, permute so the dominant direction axis is z. */
  int kx = tr->kx, ky = tr->ky, kz = tr->kz;
  vec3 a = tr_permute(tr_sub3(p0, o), kx, ky, kz);
  vec3 b = tr_permute(tr_sub3(p1, o), kx, ky, kz);
  vec3 c = tr_permute(tr_sub3(p2, o), kx, ky, kz);

  /* Shear x and y so the ray direction becomes +z. */
  real sx = tr->sx, sy = tr->sy, sz = tr->sz;
  real ax = a.x + sx * a.z, ay = a.y + sy * a.z;
  real bx = b.x + sx * b.z, by = b.y + sy * b.z;
  real cx = c.x + sx * c.z, cy = c.y + sy * c.z;

  /* Edge functions: twice the signed areas seen from the ray. */
  real e0 = bx * cy - by * cx;
  real e1 = cx * ay - cy * ax;
  real e2 = ax * by - ay * bx;
  int miss = ((e0 < TR_R(0.0)) | (e1 < TR_R(0.0)) | (e2 < TR_R(0.0))) &
             ((e0 > TR_R(0.0)) | (e1 > TR_R(0.0)) | (e2 > TR_R(0.0)));
  if (branches && miss) return 0;
  real det = e0 + e1 + e2;
  miss |= det == TR_R(0.0);
  if (branches && miss) return 0;

  /* Scaled hit distance; its sign must be the sign of det. */
  real az = sz * a.z, bz = sz * b.z, cz = sz * c.z;
  real t_scaled = e0 * az + e1 * bz + e2 * cz;
  miss |=
      ((det < TR_R(0.0)) & (t_scaled >= TR_R(0.0))) | ((det > TR_R(0.0)) & (t_scaled <= TR_R(0.0)));
  if (branches && miss) return 0;

  real inv_det = TR_R(1.0) / det;
  real t = t_scaled * inv_det;

  /* t is the barycentric average of the vertices' ray-space depths az, bz, cz (the
   * t at which the ray reaches each vertex's depth): when all three are > 0 (an exact
   * test: each is a rounded product of nonzero signed factors), the true t and the
   * computed one (a sum of same-signed terms over another) are > 0 for sure. Only
   * otherwise, when the triangle straddles the origin's plane (a ray leaving a surface),
   * reject t below pbrt-v4's conservative bound on its error ("Ensure that computed
   * triangle t is conservatively greater than zero"). That bound is loose for a needle:
   * det is tiny next to |e| max|x||y|, delta_t exceeded t and rays through the
   * needle's shared edges leaked (tests/robustness, aspect 1e7 in float). */
  int straddles = !(tr_min(az, tr_min(bz, cz)) > TR_R(0.0));
  if (may_straddle && (!branches || straddles)) {
    real max_zt = tr_max_abs(az, bz, cz);
    real max_xt = tr_max_abs(ax, bx, cx);
    real max_yt = tr_max_abs(ay, by, cy);
    real delta_z = tr_gamma(3) * max_zt;
    real delta_x = tr_gamma(5) * (max_xt + max_zt);
    real delta_y = tr_gamma(5) * (max_yt + max_zt);
    real delta_e =
        TR_R(2.0) * (tr_gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    real max_e = tr_max_abs(e0, e1, e2);
    real delta_t = TR_R(3.0) * (tr_gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) *
                   tr_fabs(inv_det);
    miss |= straddles & !(t > delta_t);
  }

  /* Zero-area triangles have no normal: never hit them. (It does not depend on the
   * ray: a loop over rays computes it once.) */
  vec3 normal = tr_cross(p1 - p0, p2 - p0);
  miss |= !(tr_dot(normal, normal) > TR_R(0.0));
  if (branches && miss) return 0;
  *bary = TR_VEC3(e0 * inv_det, e1 * inv_det, e2 * inv_det);
  *t_hit = t;
  return !miss;
}

TR_FN_INLINE vec3 tr_triangle_p0(TR_GLOBAL const TrTriangle* tri) {
  return TR_VEC3(tri->p0x, tri->p0y, tri->p0z);
}
TR_FN_INLINE vec3 tr_triangle_p1(TR_GLOBAL const TrTriangle* tri) {
  return TR_VEC3(tri->p1x, tri->p1y, tri->p1z);
}
TR_FN_INLINE vec3 tr_triangle_p2(TR_GLOBAL const TrTriangle* tri) {
  return TR_VEC3(tri->p2x, tri->p2y, tri->p2z);
}

/* The unit geometric normal, (p1 - p0) x (p2 - p0) normalized: it follows the winding. */
TR_FN_INLINE vec3 tr_triangle_unit_normal(TR_GLOBAL const TrTriangle* tri) {
  vec3 p0 = tr_triangle_p0(tri);
  vec3 normal = tr_cross(tr_triangle_p1(tri) - p0, tr_triangle_p2(tri) - p0);
  return normal * (TR_R(1.0) / tr_sqrt(tr_dot(normal, normal)));
}

/* The distance along the ray to the triangle, > 0, and the hit's barycentrics in *bary;
 * a value that is not > 0 where the ray misses. */
TR_FN_INLINE real tr_triangle_t_bary(TR_GLOBAL const TrTriangle* tri, TrRay ray,
                                     const TrTriangleRay* tr, vec3* bary) {
  real t = TR_R(0.0);
  int hit = tr_triangle_hit_at(tr_triangle_p0(tri), tr_triangle_p1(tri), tr_triangle_p2(tri), ray.o,
                               tr, 1, 1, &t, bary);
  return hit ? t : TR_R(0.0);
}

TR_FN_INLINE real tr_triangle_t(TR_GLOBAL const TrTriangle* tri, TrRay ray,
                                const TrTriangleRay* tr) {
  vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0)); /* set on a hit only */
  return tr_triangle_t_bary(tri, ray, tr, &bary);
}

/* The hit record of a ray that reaches the triangle at t (from tr_triangle_t), and the
 * hit's barycentric coordinates in *bary (for tr_triangle_attributes). The hit point
 * comes from the barycentrics: its error lies along the surface, not off it (Waechter
 * and Binder, Ray Tracing Gems ch. 6); bound gamma(7) sum |b_i p_i|. */
TR_FN void tr_triangle_record(TR_GLOBAL const TrTriangle* tri, TrRay ray, const TrTriangleRay* tr,
                              real t, TrHit* hit, vec3* bary) {
  *bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0)); /* set on a hit only */
  tr_triangle_t_bary(tri, ray, tr, bary);
  vec3 b = *bary;
  vec3 p0 = tr_triangle_p0(tri), p1 = tr_triangle_p1(tri), p2 = tr_triangle_p2(tri);
  tr_set_hit(hit, t, p0 * b.x + p1 * b.y + p2 * b.z,
             (tr_abs3(p0 * b.x) + tr_abs3(p1 * b.y) + tr_abs3(p2 * b.z)) * tr_gamma(7),
             tr_triangle_unit_normal(tri), tri->material, tri->object);
}

/* Vertex normals and texture coordinates, interpolated at the hit (barycentrics b).
 *
 * Shading normal: sum b_i n_i, normalized; the geometric normal where that sum is 0.
 *
 * Shadow terminator: a smooth normal lights the faces of a coarse mesh past the line
 * where the flat facets turn from the light, and shadow rays from the flat surface are
 * blocked there by the neighbouring facets (hard, faceted shadow edges). Hanika,
 * "Hacking the Shadow Terminator" (Ray Tracing Gems II, ch. 4, 2021): start shadow rays
 * from the point on the smooth surface the vertex normals describe. For each vertex i,
 * project p onto the tangent plane of n_i where p lies below it; the shadow origin is
 * p + sum_i b_i max(0, -(p - p_i).n_i) n_i, with each n_i turned to the side the ray
 * came from. Written as a lift added to p, so a flat neighbourhood (no vertex plane
 * above p) leaves p unchanged to the bit; the addition's rounding widens the error
 * bound by gamma(2) |origin|. */
TR_FN void tr_triangle_attributes(TR_GLOBAL const TrTriangleAttr* a,
                                  TR_GLOBAL const TrTriangle* tri, vec3 b, vec3 ray_dir,
                                  TrHit* hit) {
  if ((a->flags & TR_ATTR_UV) != 0) {
    hit->u = a->u0 * b.x + a->u1 * b.y + a->u2 * b.z;
    hit->v = a->v0 * b.x + a->v1 * b.y + a->v2 * b.z;
  }
  if ((a->flags & TR_ATTR_NORMALS) == 0) return;
  vec3 n0 = TR_VEC3(a->n0x, a->n0y, a->n0z);
  vec3 n1 = TR_VEC3(a->n1x, a->n1y, a->n1z);
  vec3 n2 = TR_VEC3(a->n2x, a->n2y, a->n2z);
  vec3 ns = n0 * b.x + n1 * b.y + n2 * b.z;
  real len2 = tr_dot(ns, ns);
  if (!(len2 > TR_R(0.0))) return; /* opposite normals cancel: keep the geometric one */
  hit->ns = ns * (TR_R(1.0) / tr_sqrt(len2));

  /* Turn the vertex normals to the side the ray came from. */
  vec3 facing = tr_dot(hit->n, ray_dir) > TR_R(0.0) ? -hit->n : hit->n;
  if (tr_dot(ns, facing) < TR_R(0.0)) {
    n0 = -n0;
    n1 = -n1;
    n2 = -n2;
  }
  vec3 p0 = tr_triangle_p0(tri), p1 = tr_triangle_p1(tri), p2 = tr_triangle_p2(tri);
  real d0 = tr_dot(hit->p - p0, n0), d1 = tr_dot(hit->p - p1, n1), d2 = tr_dot(hit->p - p2, n2);
  if (!(d0 < TR_R(0.0) || d1 < TR_R(0.0) || d2 < TR_R(0.0))) return;
  vec3 lift = n0 * (-tr_min(d0, TR_R(0.0)) * b.x) + n1 * (-tr_min(d1, TR_R(0.0)) * b.y) +
              n2 * (-tr_min(d2, TR_R(0.0)) * b.z);
  hit->shadow_p = hit->p + lift;
  hit->shadow_perr = hit->perr + tr_abs3(hit->shadow_p) * tr_gamma(2);
}

/* The whole test for one ray and one triangle, hits in (0, tmax) (tests, one-off queries). */
TR_FN int tr_intersect_triangle(TR_GLOBAL const TrTriangle* tri, TrRay ray, real tmax, TrHit* hit) {
  TrTriangleRay tr = tr_triangle_ray(ray);
  real t = tr_triangle_t(tri, ray, &tr);
  if (!(t > TR_R(0.0)) || !(t < tmax)) return 0;
  vec3 bary;
  tr_triangle_record(tri, ray, &tr, t, hit, &bary);
  return 1;
}
