/* Glass: smooth dielectric interfaces (Whitted 1980), as trace.h splits a path at them.
 *
 * Inside and outside are decided by the geometric normal alone: a ray that meets a
 * surface of a transmissive material against its normal (d.n < 0) enters the material
 * from air (index 1), and one that meets it along its normal leaves it into air. So a
 * closed mesh or a sphere is a solid of its material; objects are not nested (a glass
 * inside a glass is two interfaces with air), which makes touching and nested objects
 * behave predictably. Absorption is applied to the segment that ends where a ray leaves
 * the material (Beer-Lambert over its length, from the point where it entered).
 *
 * Only + - * / and sqrt, so both backends give the same bits (prelude.h). */

/* Fresnel reflectance of unpolarized light at a smooth dielectric interface (Born and
 * Wolf; pbrt-v4 FrDielectric): cos_i >= 0 is the cosine between the incident direction
 * (reversed) and the normal on its side, eta = n_t / n_i the ratio of the indices
 * across it. Returns 1 for total internal reflection (sin^2 of the transmitted angle,
 * sin^2_i / eta^2, reaching 1), with *cos_t = 0; otherwise *cos_t is the cosine of the
 * transmitted direction (Snell: eta sin_t = sin_i). */
TR_FN real tr_fresnel_dielectric(real cos_i, real eta, real* cos_t) {
  real sin2_i = tr_max(TR_R(0.0), TR_R(1.0) - cos_i * cos_i);
  real sin2_t = sin2_i / (eta * eta);
  if (!(sin2_t < TR_R(1.0))) {
    *cos_t = TR_R(0.0);
    return TR_R(1.0);
  }
  real ct = tr_sqrt(TR_R(1.0) - sin2_t);
  *cos_t = ct;
  real r_parallel = (eta * cos_i - ct) / (eta * cos_i + ct);
  real r_perpendicular = (cos_i - eta * ct) / (cos_i + eta * ct);
  return (r_parallel * r_parallel + r_perpendicular * r_perpendicular) * TR_R(0.5);
}

/* The refracted direction of unit direction d at a surface of unit normal n facing the
 * incoming ray (d.n = -cos_i), given eta and cos_t from tr_fresnel_dielectric:
 * t = d / eta + (cos_i / eta - cos_t) n (pbrt-v4 Refract), normalized. */
TR_FN vec3 tr_refract(vec3 d, vec3 n, real cos_i, real eta, real cos_t) {
  real inv_eta = TR_R(1.0) / eta;
  return tr_normalize(d * inv_eta + n * (cos_i * inv_eta - cos_t));
}

/* e^x for x <= 0, from + - * / only (OpenCL's exp and the C library's may differ in the
 * last place). Cody and Waite's reduction x = k ln2 + r, |r| <= ln2 / 2, with ln2 split
 * in two so that k ln2_hi is exact for |k| < 2^11; e^r from its Taylor series to r^12
 * (the remainder is below 2^-56 relative); then times 2^k, by exact multiplications by
 * powers of two (0 once they underflow). */
TR_FN real tr_exp_neg(real x) {
  if (!(x > TR_R(-1000.0))) return TR_R(0.0); /* also NaN: no light gets through */
  if (!(x < TR_R(0.0))) return TR_R(1.0);
  const real ln2_hi = TR_R(0.693145751953125); /* 11 bits: exact in float and double */
  const real ln2_lo = TR_R(1.42860682030941723212e-6);
  real k = floor(x * TR_R(1.44269504088896340736) + TR_R(0.5));
  real r = (x - k * ln2_hi) - k * ln2_lo;
  real e = TR_R(1.0);
  for (int i = 12; i >= 1; --i) e = TR_R(1.0) + e * r / (real)i;
  real scale = TR_R(1.0), factor = TR_R(0.5);
  for (int m = (int)-k; m > 0; m >>= 1) {
    if (m & 1) scale = scale * factor;
    factor = factor * factor;
  }
  return e * scale;
}

/* What survives of a path's weight over the segment that ended at `hit`, seen along
 * unit direction d, `length` long (from the surface point the ray left to hit->p, not
 * from its offset origin: far from the origin the offset is many ulps of the position,
 * a sizeable part of a thin slab): e^(-absorption length) per channel where the segment
 * ran inside a transmissive material (the ray leaves it here: d.n > 0), else exactly 1. */
TR_FN vec3 tr_absorption(const TrSceneRef* s, const TrHit* hit, vec3 d, real length) {
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  if (!(m->transmission > TR_R(0.0)) || !(tr_dot(d, hit->n) > TR_R(0.0)))
    return TR_VEC3(TR_R(1.0), TR_R(1.0), TR_R(1.0));
  return TR_VEC3(tr_exp_neg(-m->absorb_r * length), tr_exp_neg(-m->absorb_g * length),
                 tr_exp_neg(-m->absorb_b * length));
}
