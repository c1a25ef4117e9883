/* The whole path of one camera ray: closest hit, shading, then the glaze loop.
 * Glazed surfaces add glaze x (what the mirrored ray sees), the assignment's
 * reflected = d - 2 (d.n) n. OpenCL C has no recursion, so the mirror chain is a
 * loop carrying the product of the glaze factors; max_depth counts ray segments
 * (1 = camera rays only). Values stay linear HDR; clamping happens at output. */

TR_FN vec3 tr_trace(const TrSceneRef* s, TrRay ray) {
  TR_GLOBAL const TrParams* p = s->params;
  vec3 color = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  vec3 background = TR_VEC3(p->bg_r, p->bg_g, p->bg_b);
  real weight = TR_R(1.0);
  int segments = tr_use(s, TR_F_GLAZE) ? p->max_depth : 1;
  for (int depth = 0; depth < segments; ++depth) {
    TrHit hit = tr_no_hit();
    if (!tr_closest_hit(s, &ray, TR_R(INFINITY), &hit)) {
      color = color + background * weight;
      break;
    }
    color = color + tr_shade(s, &hit, ray.d) * weight;
    if (!TR_HAS(TR_F_GLAZE)) break;
    real glaze = s->materials[hit.material].glaze;
    if (!(glaze > TR_R(0.0))) break;
    vec3 n = hit.ns; /* the shading normal mirrors; the geometric one offsets */
    vec3 mirrored = tr_normalize(ray.d - n * (TR_R(2.0) * tr_dot(ray.d, n)));
    ray.o = tr_offset_ray_origin(hit.p, hit.perr, hit.n, mirrored);
    ray.d = mirrored;
    weight = weight * glaze;
  }
  return color;
}

/* Mean of the pixel's samples; the summation order is fixed, so both sides agree. */
TR_FN vec3 tr_render_pixel(const TrSceneRef* s, int px, int py) {
  TR_GLOBAL const TrParams* p = s->params;
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < p->spp; ++i) {
    TrSample2 smp = tr_sample_position_seeded(p->sampler, p->seed, i, p->spp, px, py);
    sum = sum + tr_trace(s, tr_camera_ray(p, px, py, smp));
  }
  return sum * (TR_R(1.0) / (real)p->spp);
}

/* Arbitrary output variables of the primary ray through the pixel center. */
#define TR_AOV_DEPTH 0          /* hit distance t; +inf where nothing is hit */
#define TR_AOV_NORMAL 1         /* unit geometric normal as stored (not turned); 0 where no hit */
#define TR_AOV_OBJECT 2         /* object index in the scene; -1 where no hit */
#define TR_AOV_SHADING_NORMAL 3 /* unit shading normal, not turned; 0 where no hit */
#define TR_AOV_UV 4             /* texture coordinates (u, v, 0); 0 where none */

TR_FN vec3 tr_render_aov(const TrSceneRef* s, int px, int py, int aov) {
  TrSample2 center;
  center.x = TR_R(0.5);
  center.y = TR_R(0.5);
  TrHit hit = tr_no_hit();
  TrRay camera = tr_camera_ray(s->params, px, py, center);
  int found = tr_closest_hit(s, &camera, TR_R(INFINITY), &hit);
  vec3 zero = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  if (aov == TR_AOV_NORMAL) return found ? hit.n : zero;
  if (aov == TR_AOV_SHADING_NORMAL) return found ? hit.ns : zero;
  if (aov == TR_AOV_UV) return found ? TR_VEC3(hit.u, hit.v, TR_R(0.0)) : zero;
  real v = aov == TR_AOV_DEPTH ? (found ? hit.t : TR_R(INFINITY))
                               : (found ? (real)hit.object : TR_R(-1.0));
  return TR_VEC3(v, v, v);
}

/* Framebuffer: linear RGB, 3 reals per pixel, row 0 at the top. */
TR_FN void tr_store_rgb(TR_GLOBAL real* out, int width, int px, int py, vec3 c) {
  int i = (py * width + px) * 3;
  out[i] = c.x;
  out[i + 1] = c.y;
  out[i + 2] = c.z;
}
