/* Ray/sphere intersection, numerically stable (Haines, Guenther, Akenine-Moeller,
 * "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7,
 * eqs. 7-10), with f = o - center, a = d.d, b = -f.d, c = f.f - r^2:
 *  - the roots are c/q and q/a with q = b + sign(b) sqrt(a D), so the near root of a
 *    huge sphere close by does not cancel (Press et al., Numerical Recipes 5.6);
 *  - a D, the discriminant, is taken in whichever of its two exact forms is accurate
 *    for this ray: a (r^2 - |f + (b/a) d|^2), subtracted before it is squared (Hearn and
 *    Baker), for a sphere small against its distance, where b^2 and a c are both about
 *    |f|^2 and cancel; or b^2 - a c when 2 b^2 + a|c| < a r^2, i.e. when the origin is
 *    near a big sphere and the ray is not near its tangent: there |f + (b/a) d|^2 is
 *    about r^2 and the first form keeps only ~u r^2 of absolute accuracy, which in float
 *    gave 2e4 ulp of t error on a 1e5-radius ground sphere (tests/robustness);
 *  - c itself cancels when the origin is near the surface (shadow and reflected rays,
 *    a camera close to a huge sphere): then it is recomputed from the exact difference
 *    o - center and exact squares (tr_sphere_c_accurate).
 * The hit point is then projected back onto the sphere and given pbrt-v4's error bound
 * (Sphere::BasicIntersect: p <- p r/|p|, pError = gamma(5)|p| in object space), plus the
 * rounding of the translation back to world space. */

/* c = |o - center|^2 - r^2 to about one rounding of c itself, however much it cancels:
 * o - center = h + l exactly (TwoSum), h_i^2 and r^2 as exact two-term products, and
 * |o - center|^2 = sum h_i^2 + 2 sum h_i l_i + sum l_i^2, the last term below u^2 |f|^2
 * and dropped; the terms are added by Sum2 (Ogita, Rump, Oishi 2005). */
TR_FN_INLINE real tr_sphere_c_accurate(vec3 o, vec3 center, real r) {
  real lx, ly, lz, ex, ey, ez, er, e, sum_err;
  real hx = tr_two_sum(o.x, -center.x, &lx);
  real hy = tr_two_sum(o.y, -center.y, &ly);
  real hz = tr_two_sum(o.z, -center.z, &lz);
  real px = tr_two_square(hx, &ex);
  real py = tr_two_square(hy, &ey);
  real pz = tr_two_square(hz, &ez);
  real pr = tr_two_square(r, &er);
  real s = tr_two_sum(px, py, &e);
  sum_err = e;
  s = tr_two_sum(s, pz, &e);
  sum_err = sum_err + e;
  s = tr_two_sum(s, -pr, &e);
  sum_err = sum_err + e;
  sum_err = sum_err + ((ex + ey) + (ez - er)) + TR_R(2.0) * ((hx * lx + hy * ly) + hz * lz);
  return s + sum_err;
}

/* c = f.f - r^2, rounded, off by up to gamma(4) (f.f + r^2); where it is below half of
 * that sum the rounded value would carry more than 8 ulp of error, and it is recomputed
 * (a relative test: the same at any scale). */
TR_FN_INLINE real tr_sphere_c(vec3 f, vec3 o, vec3 center, real r, int branches) {
  real ff = tr_dot(f, f);
  real r2 = r * r;
  real c = ff - r2;
  int cancels = tr_fabs(c) < TR_R(0.5) * (ff + r2);
  if (branches && !cancels) return c;
  real accurate = tr_sphere_c_accurate(o, center, r);
  return cancels ? accurate : c;
}

/* Whether the ray meets the sphere (center, r) where it first enters or leaves it
 * (with `from` 1, a constant: the first of the two from tmin on), and the distance
 * along the ray there in *t (> 0 for a hit in front of the origin; a value that is not
 * > 0 otherwise). Only t: the hit record is made once per ray, for
 * the nearest primitive (tr_sphere_record). With `branches` 1 (one ray) the test skips
 * what it does not need and returns at the first miss; with 0 (a constant, in a loop
 * that runs a ray per SIMD lane: bvh_packet.h) it has no control flow: both forms of
 * the discriminant and of c are computed and selected. Both give the same answer and
 * t from the same operations. Its vectors are built from scalars (tr_sub3): the same
 * operations in the same order as vec3 arithmetic, so the same bits, but no float3
 * arithmetic, which would leave PoCL running that loop a ray at a time. */
TR_FN_INLINE int tr_sphere_hit_from(vec3 center, real r, TrRay ray, int branches, int from,
                                    real tmin, real* t_hit) {
  vec3 f = tr_sub3(ray.o, center);
  real a = tr_dot(ray.d, ray.d);
  real b = -tr_dot(f, ray.d); /* b' in the chapter */
  real r2 = r * r;
  real b_a = b / a;
  vec3 perp = TR_VEC3(f.x + ray.d.x * b_a, f.y + ray.d.y * b_a, f.z + ray.d.z * b_a);
  real root_arg = a * (r2 - tr_dot(perp, perp)); /* a D, Hearn and Baker's form */
  real c = TR_R(0.0);
  /* 2 b^2 + a|c| < a r^2 needs 2 b^2 < a r^2 first: the common miss (a sphere off to
   * the side, |b| ~ |f| > r) pays one compare for it. */
  int near = TR_R(2.0) * (b * b) < a * r2;
  if (!branches || near) {
    c = tr_sphere_c(f, ray.o, center, r, branches);
    int accurate = near & (TR_R(2.0) * (b * b) + a * tr_fabs(c) < a * r2);
    root_arg = accurate ? b * b - a * c : root_arg;
  }
  int miss = root_arg < TR_R(0.0);
  if (branches && miss) return 0;
  if (branches && !near) c = tr_sphere_c(f, ray.o, center, r, branches);
  real root = tr_sqrt(root_arg); /* NaN where root_arg < 0: a miss, selected away */
  real q = b + (b >= TR_R(0.0) ? root : -root);
  miss |= q == TR_R(0.0); /* origin on the sphere and tangent: no finite root */
  if (branches && miss) return 0;
  real t0 = c / q;
  real t1 = q / a;
  real t_near = t0 > t1 ? t1 : t0, t_far = t0 > t1 ? t0 : t1;
  *t_hit = t_near > TR_R(0.0) && (!from || t_near >= tmin) ? t_near : t_far;
  return !miss;
}

TR_FN_INLINE int tr_sphere_hit_at(vec3 center, real r, TrRay ray, int branches, real* t_hit) {
  return tr_sphere_hit_from(center, r, ray, branches, 0, TR_R(0.0), t_hit);
}

TR_FN_INLINE vec3 tr_sphere_center(TR_GLOBAL const TrSphere* sp) {
  return TR_VEC3(sp->cx, sp->cy, sp->cz);
}

/* Distance along the ray to where it first enters or leaves the sphere, > 0; a value
 * that is not > 0 (0, or NaN) where the ray misses. */
TR_FN_INLINE real tr_sphere_t(TR_GLOBAL const TrSphere* sp, TrRay ray) {
  real t = TR_R(0.0);
  int hit = tr_sphere_hit_at(tr_sphere_center(sp), sp->radius, ray, 1, &t);
  return hit ? t : TR_R(0.0);
}

/* The same from tmin on (ray queries): where the ray enters the sphere before tmin,
 * the distance to where it leaves. */
TR_FN_INLINE real tr_sphere_t_from(TR_GLOBAL const TrSphere* sp, TrRay ray, real tmin) {
  real t = TR_R(0.0);
  int hit = tr_sphere_hit_from(tr_sphere_center(sp), sp->radius, ray, 1, 1, tmin, &t);
  return hit ? t : TR_R(0.0);
}

/* The hit record at distance t along the ray (t from tr_sphere_t). */
TR_FN void tr_sphere_record(TR_GLOBAL const TrSphere* sp, TrRay ray, real t, TrHit* hit) {
  vec3 center = tr_sphere_center(sp);
  real r = sp->radius;
  vec3 rel = (ray.o - center) + ray.d * t;
  rel = rel * (r / tr_length(rel)); /* refine onto the surface */
  tr_set_hit(hit, t, center + rel,
             tr_abs3(rel) * tr_gamma(5) + (tr_abs3(center) + tr_abs3(rel)) * tr_gamma(1),
             rel * (TR_R(1.0) / r), sp->material, sp->object);
}

/* The whole test for one ray and one sphere, hits in (0, tmax) (tests, one-off queries). */
TR_FN int tr_intersect_sphere(TR_GLOBAL const TrSphere* sp, TrRay ray, real tmax, TrHit* hit) {
  real t = tr_sphere_t(sp, ray);
  if (!(t > TR_R(0.0)) || !(t < tmax)) return 0;
  tr_sphere_record(sp, ray, t, hit);
  return 1;
}
