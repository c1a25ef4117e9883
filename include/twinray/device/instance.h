/* Instances: a ray enters an asset through the instance's world-to-object map, and a hit
 * found there comes back to the world through the object-to-world map (TrInstance,
 * types.h). The direction is mapped but not normalized, so the distance t along the
 * ray is the same number in both spaces: the walk compares hits of every instance and
 * of the scene's own primitives by one t (bvh_traverse.h). Every product and sum is
 * written out in a fixed order, so both backends round the same way. */

/* Row r of a 3 x 4 affine map (x, y, z, translation) applied to a point, and to a
 * vector (no translation). */
TR_FN_INLINE real tr_affine_row_point(TR_GLOBAL const real* m, int r, vec3 p) {
  return ((m[4 * r] * p.x + m[4 * r + 1] * p.y) + m[4 * r + 2] * p.z) + m[4 * r + 3];
}
TR_FN_INLINE real tr_affine_row_vector(TR_GLOBAL const real* m, int r, vec3 v) {
  return (m[4 * r] * v.x + m[4 * r + 1] * v.y) + m[4 * r + 2] * v.z;
}
TR_FN_INLINE vec3 tr_affine_point(TR_GLOBAL const real* m, vec3 p) {
  return TR_VEC3(tr_affine_row_point(m, 0, p), tr_affine_row_point(m, 1, p),
                 tr_affine_row_point(m, 2, p));
}
TR_FN_INLINE vec3 tr_affine_vector(TR_GLOBAL const real* m, vec3 v) {
  return TR_VEC3(tr_affine_row_vector(m, 0, v), tr_affine_row_vector(m, 1, v),
                 tr_affine_row_vector(m, 2, v));
}

/* A normal maps by the inverse transpose: here the transpose of the world-to-object
 * map's linear part. It keeps a closed surface's outward side outward under every
 * invertible map, mirrors (negative determinant) included, where the cross product of
 * mapped edges would flip with the winding. Unit length again. */
TR_FN_INLINE vec3 tr_instance_normal(TR_GLOBAL const TrInstance* in, vec3 n) {
  TR_GLOBAL const real* m = in->to_object;
  vec3 w = TR_VEC3((m[0] * n.x + m[4] * n.y) + m[8] * n.z, (m[1] * n.x + m[5] * n.y) + m[9] * n.z,
                   (m[2] * n.x + m[6] * n.y) + m[10] * n.z);
  return tr_normalize(w);
}

/* The ray in the asset's space. */
TR_FN_INLINE TrRay tr_instance_ray(TR_GLOBAL const TrInstance* in, TrRay ray) {
  TrRay mapped;
  mapped.o = tr_affine_point(in->to_object, ray.o);
  mapped.d = tr_affine_vector(in->to_object, ray.d);
  return mapped;
}

/* A point p with error bound e, mapped to the world: the mapped point and its bound,
 * pbrt-v4's Transform::operator()(Point3fi) (Pharr, Jakob, Humphreys, 4th ed., 6.8.6):
 * (1 + gamma(3)) sum |m_ij| e_j + gamma(3) (sum |m_ij p_j| + |m_i3|). The two maps are
 * each rounded to real from one double-precision pair, so they are inverses only to
 * about a rounding of their entries; gamma(5) for gamma(3) covers that too. */
TR_FN_INLINE void tr_instance_point_to_world(TR_GLOBAL const TrInstance* in, vec3* p_io,
                                             vec3* e_io) {
  TR_GLOBAL const real* m = in->to_world;
  vec3 p = *p_io, e = *e_io;
  real g = tr_gamma(5);
  real out[3], err[3];
  for (int r = 0; r < 3; ++r) {
    real a0 = tr_fabs(m[4 * r]), a1 = tr_fabs(m[4 * r + 1]), a2 = tr_fabs(m[4 * r + 2]);
    real spread =
        ((tr_fabs(m[4 * r] * p.x) + tr_fabs(m[4 * r + 1] * p.y)) + tr_fabs(m[4 * r + 2] * p.z)) +
        tr_fabs(m[4 * r + 3]);
    err[r] = (TR_R(1.0) + g) * ((a0 * e.x + a1 * e.y) + a2 * e.z) + g * spread;
    out[r] = tr_affine_row_point(m, r, p);
  }
  *p_io = TR_VEC3(out[0], out[1], out[2]);
  *e_io = TR_VEC3(err[0], err[1], err[2]);
}

/* A hit record made in the asset's space (scene_hit.h), brought to the world: points
 * with their error bounds, the normals, and the instance's material and object. */
TR_FN void tr_instance_hit_to_world(TR_GLOBAL const TrInstance* in, TrHit* hit) {
  tr_instance_point_to_world(in, &hit->p, &hit->perr);
  tr_instance_point_to_world(in, &hit->shadow_p, &hit->shadow_perr);
  hit->n = tr_instance_normal(in, hit->n);
  hit->ns = tr_instance_normal(in, hit->ns);
  if (in->material >= 0) hit->material = in->material;
  hit->object = in->object;
}
