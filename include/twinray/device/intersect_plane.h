/* Ray/infinite-plane intersection. A ray parallel to the plane (d.n == 0) misses, and
 * so does one whose t is not finite and inside (0, tmax): that also covers a ray lying
 * in the plane (0/0). The hit point is projected back onto the plane, which removes
 * the error of t along the normal; what is left is the rounding of the projection,
 * bounded by gamma(8) (|p| + |point|) per axis (our derivation: 3 roundings for
 * p - point, 3 for the dot product, 2 for the correction). */

/* Whether the ray can meet the plane through `point` with normal n (it is not
 * parallel to it), and the distance along the ray in *t. No branch and no float3
 * arithmetic, so that a loop over rays vectorizes in g++ and on PoCL (scene_hit.h). */
TR_FN_INLINE int tr_plane_hit_at(vec3 n, vec3 point, TrRay ray, real* t) {
  real denom = tr_dot(ray.d, n);
  *t = tr_dot(tr_sub3(point, ray.o), n) / denom;
  return denom != TR_R(0.0);
}

TR_FN_INLINE vec3 tr_plane_normal(TR_GLOBAL const TrPlane* pl) {
  return TR_VEC3(pl->nx, pl->ny, pl->nz);
}
TR_FN_INLINE vec3 tr_plane_point(TR_GLOBAL const TrPlane* pl) {
  return TR_VEC3(pl->px, pl->py, pl->pz);
}

/* Distance along the ray to the plane; a value that is not > 0 (0, negative, NaN or
 * infinite is left to the caller's range test) where the ray misses it. */
TR_FN_INLINE real tr_plane_t(TR_GLOBAL const TrPlane* pl, TrRay ray) {
  real t;
  int hit = tr_plane_hit_at(tr_plane_normal(pl), tr_plane_point(pl), ray, &t);
  return hit ? t : TR_R(0.0);
}

/* The hit record of a ray that reaches the plane at t (from tr_plane_t). */
TR_FN void tr_plane_record(TR_GLOBAL const TrPlane* pl, TrRay ray, real t, TrHit* hit) {
  vec3 n = tr_plane_normal(pl), point = tr_plane_point(pl);
  vec3 p = ray.o + ray.d * t;
  p = p - n * tr_dot(p - point, n);
  tr_set_hit(hit, t, p, (tr_abs3(p) + tr_abs3(point)) * tr_gamma(8), n, pl->material, pl->object);
}

/* The whole test for one ray and one plane, hits in (0, tmax) (tests, one-off queries). */
TR_FN int tr_intersect_plane(TR_GLOBAL const TrPlane* pl, TrRay ray, real tmax, TrHit* hit) {
  real t = tr_plane_t(pl, ray);
  if (!(t > TR_R(0.0)) || !(t < tmax)) return 0;
  tr_plane_record(pl, ray, t, hit);
  return 1;
}
