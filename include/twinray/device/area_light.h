/* Area lights: a rect (corner c, edges e1, e2) or a sphere (center c, radius r) that
 * shading sees as n x n point lights, each of 1/n^2 of the light's intensity, placed
 * anew for every path by stratified jitter (Cook, Porter and Carpenter 1984,
 * "Distributed ray tracing"). Each sample is shaded by the point light's formulas
 * (shading.h), with its own shadow ray, so the penumbra is the share of samples a
 * blocker hides: it widens with the light, and the pixel's samples, each with its own
 * sample positions, average it (adaptive sampling refines where it is noisy). A sample
 * emits in every direction, like a point light, so a light shrunk to a point becomes
 * the point light of the same intensity.
 *
 * Sample k of n^2 sits in cell (k mod n, k / n) of the light's n x n grid, jittered
 * inside it by tr_sample_stratified (sampling.h) from a word of the path (its pixel,
 * sample index and seed: tr_path_seed) and the light's index: integer arithmetic and
 * exact fixed-point positions, so both backends place it at the same bits.
 *   rect:   c + x e1 + y e2, for the cell position (x, y) in [0, 1)^2;
 *   sphere: the disk of radius r through c that faces the shaded point p (the sphere's
 *           outline as p sees it, exactly so far from it), the square [-1, 1]^2 mapped
 *           onto it by Fong's elliptical grid mapping (2015, "Analytical methods for
 *           squaring the disc"), which needs only sqrt, in the basis of Duff et al.
 *           (2017, "Building an orthonormal basis, revisited") about c -> p. */

/* The word a path's light samples come from: one per pixel, sample index and seed,
 * apart from the words that jitter the camera sample (sampling.h). */
TR_FN unsigned int tr_path_seed(int px, int py, int sample, int seed) {
  return tr_hash_u32(tr_pixel_hash(px, py, seed) ^ tr_hash_u32((unsigned int)sample + 0x632be5abu));
}

/* How many shadow samples light i takes: n^2 for an area light, 1 for a point. */
TR_FN int tr_light_samples(const TrSceneRef* s, int i) {
  if (!tr_use(s, TR_F_AREA_LIGHTS) || s->lights[i].shape == TR_LIGHT_POINT) return 1;
  int n = s->lights[i].samples;
  return n * n;
}

/* Where sample k of light i is, for a path of seed word `seed` shading point p. */
TR_FN_NOINLINE vec3 tr_light_sample_position(const TrSceneRef* s, int i, int k, unsigned int seed,
                                             vec3 p) {
  TR_GLOBAL const TrLight* light = &s->lights[i];
  vec3 c = TR_VEC3(light->px, light->py, light->pz);
  if (!tr_use(s, TR_F_AREA_LIGHTS) || light->shape == TR_LIGHT_POINT) return c;
  int n = light->samples;
  TrSample2 cell =
      tr_sample_stratified(k, n * n, tr_hash_u32(seed + (unsigned int)i * 0x9e3779b9u));
  if (light->shape == TR_LIGHT_RECT)
    return c + TR_VEC3(light->e1x, light->e1y, light->e1z) * cell.x +
           TR_VEC3(light->e2x, light->e2y, light->e2z) * cell.y;
  /* sphere: w, the unit direction from its center to p (+z where p is the center) */
  vec3 w = tr_sub3(p, c);
  real len = tr_length(w);
  w = len > TR_R(0.0) ? tr_scale3(w, TR_R(1.0) / len) : TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(1.0));
  real sign = w.z >= TR_R(0.0) ? TR_R(1.0) : TR_R(-1.0);
  real a = TR_R(-1.0) / (sign + w.z);
  real b = w.x * w.y * a;
  vec3 t1 = TR_VEC3(TR_R(1.0) + sign * w.x * w.x * a, sign * b, -sign * w.x);
  vec3 t2 = TR_VEC3(b, sign + w.y * w.y * a, -w.y);
  real u = TR_R(2.0) * cell.x - TR_R(1.0), v = TR_R(2.0) * cell.y - TR_R(1.0);
  real x = u * tr_sqrt(TR_R(1.0) - v * v * TR_R(0.5));
  real y = v * tr_sqrt(TR_R(1.0) - u * u * TR_R(0.5));
  return c + (t1 * x + t2 * y) * light->radius;
}
