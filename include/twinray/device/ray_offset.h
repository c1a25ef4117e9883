/* Origins of secondary rays (shadow, glaze), offset off the surface by the hit point's
 * own error bound instead of a fixed epsilon (pbrt-v4 OffsetRayOrigin; Pharr, Jakob,
 * Humphreys, PBR 4th ed. 6.8.6; Waechter and Binder, Ray Tracing Gems ch. 6):
 * move along the geometric normal by |n| . perr, to the side the new ray leaves from,
 * then round each moved coordinate one more ulp away from the surface. The offset
 * scales with the hit point's magnitude, so a scene at 1e-4 and at 1e5 behaves alike. */

TR_FN vec3 tr_offset_ray_origin(vec3 p, vec3 perr, vec3 n, vec3 w) {
  real dist = tr_dot(tr_abs3(n), perr);
  vec3 offset = n * dist;
  if (tr_dot(w, n) < TR_R(0.0)) offset = -offset;
  vec3 po = p + offset;
  real up = TR_R(INFINITY), down = -TR_R(INFINITY);
  po.x = offset.x > TR_R(0.0) ? nextafter(po.x, up)
                              : (offset.x < TR_R(0.0) ? nextafter(po.x, down) : po.x);
  po.y = offset.y > TR_R(0.0) ? nextafter(po.y, up)
                              : (offset.y < TR_R(0.0) ? nextafter(po.y, down) : po.y);
  po.z = offset.z > TR_R(0.0) ? nextafter(po.z, up)
                              : (offset.z < TR_R(0.0) ? nextafter(po.z, down) : po.z);
  return po;
}
