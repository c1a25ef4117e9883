/* Ray/infinite-plane intersection. A ray parallel to the plane (d.n == 0) misses, and
 * so does one whose t is not finite and inside (0, tmax): that also covers a ray lying
 * in the plane (0/0). The hit point is projected back onto the plane, which removes
 * the error of t along the normal; what is left is the rounding of the projection,
 * bounded by gamma(8) (|p| + |point|) per axis (our derivation: 3 roundings for
 * p - point, 3 for the dot product, 2 for the correction). */

/* Distance along the ray to the plane; a value that is not > 0 (0, negative, NaN or
 * infinite is left to the caller's range test) where the ray misses it. */
TR_FN_INLINE real tr_plane_t(TR_GLOBAL const TrPlane* pl, TrRay ray) {
  vec3 n = TR_VEC3(pl->nx, pl->ny, pl->nz);
  vec3 point = TR_VEC3(pl->px, pl->py, pl->pz);
  real denom = tr_dot(ray.d, n);
  if (denom == TR_R(0.0)) return TR_R(0.0);
  return tr_dot(point - ray.o, n) / denom;
}

/* The hit record of a ray that reaches the plane at t (from tr_plane_t). */
TR_FN void tr_plane_record(TR_GLOBAL const TrPlane* pl, TrRay ray, real t, TrHit* hit) {
  vec3 n = TR_VEC3(pl->nx, pl->ny, pl->nz);
  vec3 point = TR_VEC3(pl->px, pl->py, pl->pz);
  vec3 p = ray.o + ray.d * t;
  p = p - n * tr_dot(p - point, n);
  hit->t = t;
  hit->p = p;
  hit->perr = (tr_abs3(p) + tr_abs3(point)) * tr_gamma(8);
  hit->n = n;
  hit->material = pl->material;
  hit->object = pl->object;
}

/* The whole test for one ray and one plane, hits in (0, tmax) (tests, one-off queries). */
TR_FN int tr_intersect_plane(TR_GLOBAL const TrPlane* pl, TrRay ray, real tmax, TrHit* hit) {
  real t = tr_plane_t(pl, ray);
  if (!(t > TR_R(0.0)) || !(t < tmax)) return 0;
  tr_plane_record(pl, ray, t, hit);
  return 1;
}
