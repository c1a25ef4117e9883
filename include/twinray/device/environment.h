/* The environment: an equirectangular (latitude-longitude) image around the scene, seen
 * by every ray that hits nothing (camera, mirror and refracted rays alike) in place of
 * the background color. It does not light the scene: a Whitted model's light comes
 * from its lights alone.
 *
 * A direction is first taken into the environment's frame (its up vector, +y unless
 * the scene says otherwise, with forward the part of -z, or else of +x, normal to it,
 * and right = forward x up). Direction d (unit) in that frame looks at u = 1/2 + atan2(d.x, -d.z) /
 * (2 pi) - turns, where turns = rotate_degrees / 360, and at v = 1 - acos(d.y) / pi: the image's
 * top row is straight up (+y), its bottom row straight down, its middle column is seen along -z
 * (the default camera's view), and u grows to the right as the view turns toward +x. A positive
 * rotation turns the map so that what was seen along -x is seen along -z at 90 degrees. Bilinear
 * between texel centers, wrapping around in u and clamped at the poles in v (texture.h); texels
 * times the environment's intensity.
 *
 * atan2 and acos are computed here from + - * / and sqrt only, so both backends give
 * the same bits (OpenCL's atan2 is not correctly rounded, and not the C library's):
 * acos(y) = atan2(sqrt(x^2 + z^2), y) for a unit d, and atan on [0, 1] is reduced to
 * [-tan(pi/8), tan(pi/8)] and taken by the polynomial of Cephes' atanf (S. Moshier),
 * off by about 1e-8 rad in double and 3e-7 in float (tests/device/environment_test.cpp):
 * a thousandth of a texel of a 32768-texel-wide map at most. */

/* atan(x) for x in [0, 1]. */
TR_FN real tr_atan_unit(real x) {
  real base = TR_R(0.0);
  if (x > TR_R(0.41421356237309504880)) { /* tan(pi/8) */
    base = TR_R(0.78539816339744830962);  /* atan(1) = pi/4; atan((x-1)/(x+1)) + pi/4 */
    x = (x - TR_R(1.0)) / (x + TR_R(1.0));
  }
  real z = x * x;
  real poly =
      ((TR_R(8.05374449538e-2) * z - TR_R(1.38776856032e-1)) * z + TR_R(1.99777106478e-1)) * z -
      TR_R(3.33329491539e-1);
  return base + (poly * z * x + x);
}

/* The angle of (x, y) from the +x axis, in [-pi, pi]: atan2(y, x) to within the error
 * above; 0 for (0, 0). */
TR_FN real tr_atan2(real y, real x) {
  real ax = tr_fabs(x), ay = tr_fabs(y);
  real big = tr_max(ax, ay), small = tr_min(ax, ay);
  real a = big > TR_R(0.0) ? tr_atan_unit(small / big) : TR_R(0.0);
  if (ay > ax) a = TR_R(1.57079632679489661923) - a; /* pi/2 */
  if (x < TR_R(0.0)) a = TR_R(3.14159265358979323846) - a;
  return y < TR_R(0.0) ? -a : a;
}

/* The environment's color along unit direction d. */
TR_FN_NOINLINE vec3 tr_environment_rgb(const TrSceneRef* s, vec3 world) {
  TR_GLOBAL const TrParams* p = s->params;
  /* d in the environment's frame: right, up and back (-forward) as x, y and z */
  vec3 d = TR_VEC3(tr_dot(world, TR_VEC3(p->env_right_x, p->env_right_y, p->env_right_z)),
                   tr_dot(world, TR_VEC3(p->env_up_x, p->env_up_y, p->env_up_z)),
                   -tr_dot(world, TR_VEC3(p->env_forward_x, p->env_forward_y, p->env_forward_z)));
  real inv_two_pi = TR_R(0.15915494309189533577);
  real u = TR_R(0.5) + tr_atan2(d.x, -d.z) * inv_two_pi - p->env_turns;
  real polar = tr_atan2(tr_sqrt(d.x * d.x + d.z * d.z), d.y); /* acos(d.y), in [0, pi] */
  real v = TR_R(1.0) - polar * (TR_R(2.0) * inv_two_pi);
  return tr_texture_sample(s, p->environment, u, v, 1) * p->env_intensity;
}

/* What a ray of direction d that hits nothing sees: the environment, or the background
 * color. */
TR_FN vec3 tr_miss_rgb(const TrSceneRef* s, vec3 d) {
  TR_GLOBAL const TrParams* p = s->params;
  if (tr_use(s, TR_F_ENVIRONMENT) && p->environment >= 0) return tr_environment_rgb(s, d);
  return TR_VEC3(p->bg_r, p->bg_g, p->bg_b);
}
