/* x moved g further from 0 (g >= 0); 0 stays 0. */
TR_FN_INLINE real tr_grow_away_from_zero(real x, real g) {
  return x > TR_R(0.0) ? x + g : (x < TR_R(0.0) ? x - g : x);
}

/* Origins of secondary rays (shadow, glaze), offset off the surface by the hit point's
 * own error bound instead of a fixed epsilon (pbrt-v4 OffsetRayOrigin; Pharr, Jakob,
 * Humphreys, PBR 4th ed. 6.8.6; Waechter and Binder, Ray Tracing Gems ch. 6): move
 * along the geometric normal by |n| . perr, to the side the new ray leaves from. The
 * offset scales with the hit point's magnitude, so a scene at 1e-4 and at 1e5 behaves
 * alike.
 *
 * Rounding p + o may fall back toward the surface by up to u |p + o| (u the unit
 * roundoff). pbrt steps each moved coordinate one ulp on with nextafter; here each
 * nonzero component of o grows instead by g = 4u (|p| + |o|) before the sum, in plain
 * arithmetic (no call, no bit steps). Then, per component, sign(o) (fl(p + o') - p) >=
 * |o'| (1 - u) - u |p| >= (|o| + g)(1 - u)^2 - u |p| >= |o|, since the rounded g is
 * at least 4u (|p| + |o|)(1 - u), so g (1 - u)^2 >= 2u |o| + u |p|: the origin lands
 * at least as far off the surface as p + o, never nearer (sums of subnormals, where g
 * loses bits, are exact). */
TR_FN vec3 tr_offset_ray_origin(vec3 p, vec3 perr, vec3 n, vec3 w) {
  real dist = tr_dot(tr_abs3(n), perr);
  if (tr_dot(w, n) < TR_R(0.0)) dist = -dist;
  vec3 o = tr_scale3(n, dist);
  vec3 g = tr_scale3(tr_add3(tr_abs3(p), tr_abs3(o)), TR_R(4.0) * tr_unit_roundoff());
  o.x = tr_grow_away_from_zero(o.x, g.x);
  o.y = tr_grow_away_from_zero(o.y, g.y);
  o.z = tr_grow_away_from_zero(o.z, g.z);
  return tr_add3(p, o);
}
