/* Ray/sphere intersection, numerically stable (Haines, Guenther, Akenine-Moeller,
 * "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7,
 * eqs. 7-10):
 *  - the discriminant is r^2 - |f - (f.d/d.d) d|^2, subtracted before it is squared,
 *    so a tiny sphere far away keeps its radius's bits (Hearn and Baker);
 *  - the roots are q/a and c/q with q = b' + sign(b') sqrt(a D), so the near root of a
 *    huge sphere close by does not cancel (Press et al., Numerical Recipes 5.6).
 * The hit point is then projected back onto the sphere and given pbrt-v4's error bound
 * (Sphere::BasicIntersect: p <- p r/|p|, pError = gamma(5)|p| in object space), plus the
 * rounding of the translation back to world space. */

TR_FN int tr_intersect_sphere(TR_GLOBAL const TrSphere* sp, TrRay ray, real tmax, TrHit* hit) {
  vec3 center = TR_VEC3(sp->cx, sp->cy, sp->cz);
  real r = sp->radius;
  vec3 f = ray.o - center;
  real a = tr_dot(ray.d, ray.d);
  real b = -tr_dot(f, ray.d); /* b' in the chapter */
  vec3 perp = f + ray.d * (b / a);
  real disc = r * r - tr_dot(perp, perp);
  if (disc < TR_R(0.0)) return 0;
  real c = tr_dot(f, f) - r * r;
  real q = b + (b >= TR_R(0.0) ? sqrt(a * disc) : -sqrt(a * disc));
  if (q == TR_R(0.0)) return 0; /* origin on the sphere and tangent: no finite root */
  real t0 = c / q;
  real t1 = q / a;
  if (t0 > t1) {
    real tmp = t0;
    t0 = t1;
    t1 = tmp;
  }
  real t = t0 > TR_R(0.0) ? t0 : t1;
  if (!(t > TR_R(0.0)) || !(t < tmax)) return 0;

  vec3 rel = f + ray.d * t;
  rel = rel * (r / tr_length(rel)); /* refine onto the surface */
  vec3 p = center + rel;
  hit->t = t;
  hit->p = p;
  hit->perr = tr_abs3(rel) * tr_gamma(5) + (tr_abs3(center) + tr_abs3(rel)) * tr_gamma(1);
  hit->n = rel * (TR_R(1.0) / r);
  hit->material = sp->material;
  hit->object = sp->object;
  return 1;
}
