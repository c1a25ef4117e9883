/* Blinn-Phong shading with shadows (the original assignment's formulas), in linear RGB. For
 * each point light (and each shadow sample of an area light: area_light.h), with C the material
 * color and E = intensity x color / d^2 the light's irradiance at distance d (inverse-square law):
 *   ambient  = ka C E
 *   diffuse  = kd C E max(0, n.l)
 *   specular = ks E max(0, n.h)^shininess       h = normalize(l + v)
 * A point whose shadow ray toward the light is blocked gets the ambient term only.
 * n is the shading normal (the geometric one, or a mesh's interpolated vertex normal)
 * turned to the side of the geometric normal that faces the incoming ray, so
 * triangles and planes are lit from whichever side is seen. C is the material color,
 * times its texture at the hit's uv where it has one (texture.h). Each term and the
 * shadow rays can be switched off (Features mask). */

/* The shadow ray toward the light from a hit's shadow origin p (the hit point, or its
 * lift off a smooth mesh: intersect_triangle.h), whose error is bounded by perr and
 * whose geometric normal is ng, and the distance it must stay clear for: p offset
 * along ng by the error bound. Returns 0 where there is none (the offset origin is at
 * the light); *shadow and *tmax are set either way, so that a loop over hits
 * (trace.h) needs no branch here and runs a hit per SIMD lane. */
TR_FN int tr_shadow_ray(vec3 p, vec3 perr, vec3 ng, vec3 light_pos, TrRay* shadow, real* tmax) {
  shadow->o = tr_offset_ray_origin(p, perr, ng, tr_sub3(light_pos, p));
  vec3 to_light = tr_sub3(light_pos, shadow->o);
  real dist = tr_length(to_light);
  shadow->d = tr_scale3(to_light, TR_R(1.0) / dist);
  /* Stop just short of the light (1 - 2^-13 of the way), so geometry the light sits
   * on does not shadow it: a relative margin, the same at every scale. */
  *tmax = dist * TR_R(0.9998779296875);
  return dist > TR_R(0.0);
}

/* The normal the hit is shaded with: the shading normal, turned to the side of the
 * geometric normal that faces the incoming ray. */
TR_FN vec3 tr_facing_normal(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir) {
  vec3 n = tr_dot(hit->n, ray_dir) > TR_R(0.0) ? -hit->n : hit->n;
  if (tr_use(s, TR_F_ATTRIBUTES)) n = tr_dot(hit->ns, n) < TR_R(0.0) ? -hit->ns : hit->ns;
  return n;
}

/* Light i, or its sample at light_pos (area_light.h), as seen from the hit point p with
 * facing normal n. Every field is set whichever terms are lit, with no branch: a loop
 * over hits (trace.h) runs a hit per SIMD lane. */
TR_FN TrLightView tr_light_view(const TrSceneRef* s, vec3 p, vec3 n, int i, vec3 light_pos) {
  TR_GLOBAL const TrLight* light = &s->lights[i];
  TrLightView lv;
  lv.pos = light_pos;
  vec3 to_light = tr_sub3(lv.pos, p);
  real dist2 = tr_dot(to_light, to_light);
  lv.irradiance = tr_scale3(TR_VEC3(light->r, light->g, light->b), TR_R(1.0) / dist2);
  lv.l = tr_scale3(to_light, TR_R(1.0) / tr_sqrt(dist2));
  lv.n_dot_l = tr_dot(n, lv.l);
  int directional = tr_use(s, TR_F_DIFFUSE) || tr_use(s, TR_F_SPECULAR);
  lv.lit = !(dist2 > TR_R(0.0))                    ? TR_LIGHT_NONE
           : directional && lv.n_dot_l > TR_R(0.0) ? TR_LIGHT_ALL /* else: behind it */
                                                   : TR_LIGHT_AMBIENT;
  return lv;
}

/* What shading the hit reads before its lights: the albedo (the material color, times
 * its texture at the hit's uv) and the facing normal. */
TR_FN TrSurface tr_surface(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir) {
  TrSurface sf;
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  sf.albedo = TR_VEC3(m->r, m->g, m->b);
  if (tr_use(s, TR_F_TEXTURES) && m->texture >= 0)
    sf.albedo = sf.albedo * tr_texture_rgb(s, m->texture, hit->u, hit->v);
  sf.n = tr_facing_normal(s, hit, ray_dir);
  return sf;
}

/* Whether the light seen as lv asks for a shadow ray (then *shadow and *tmax say what
 * to trace): shadows on, the light in front of the surface, and a term it would add.
 * The ray starts from shadow origin p with error bound perr on a surface of geometric
 * normal ng (tr_shadow_ray). */
TR_FN int tr_light_needs_shadow_ray(const TrSceneRef* s, TrLightView lv, vec3 p, vec3 perr, vec3 ng,
                                    TrRay* shadow, real* tmax) {
  int traced = tr_shadow_ray(p, perr, ng, lv.pos, shadow, tmax); /* no branch: as above */
  return tr_use(s, TR_F_SHADOWS) & (lv.lit == TR_LIGHT_ALL) & traced;
}

/* The share of a light that reaches a point past glass, on a shadow ray that an
 * any-hit test found blocked: the product of the transmission of each transmissive
 * surface the ray crosses before tmax, 0 at the first opaque one (or past
 * TR_SHADOW_CROSSINGS surfaces). A glass object's shadow is tinted by its transmission
 * only: light is not bent or absorbed on its way (a Whitted model has no caustics). */
#define TR_SHADOW_CROSSINGS 16
TR_FN real tr_shadow_transmittance(const TrSceneRef* s, TrRay shadow, real tmax) {
  real through = TR_R(1.0);
  for (int k = 0; k < TR_SHADOW_CROSSINGS; ++k) {
    TrHit hit = tr_no_hit();
    if (!tr_closest_hit(s, &shadow, tmax, &hit)) return through;
    real transmission = s->materials[hit.material].transmission;
    if (!(transmission > TR_R(0.0))) return TR_R(0.0);
    through = through * transmission;
    shadow.o = tr_offset_ray_origin(hit.p, hit.perr, hit.n, shadow.d);
    tmax = tmax - hit.t;
    if (!(tmax > TR_R(0.0))) return through;
  }
  return TR_R(0.0);
}

/* What passes glass on a shadow ray (from tr_shadow_ray) that an any-hit test found
 * *blocked: tr_shadow_transmittance where glass is compiled in and the ray is blocked,
 * which leaves *blocked set only where nothing passes; else 1. */
TR_FN real tr_shadow_through(const TrSceneRef* s, TrRay shadow, real tmax, int* blocked) {
  if (!tr_use(s, TR_F_DIELECTRIC) || !*blocked) return TR_R(1.0);
  real through = tr_shadow_transmittance(s, shadow, tmax);
  *blocked = !(through > TR_R(0.0));
  return through;
}

/* sum plus the light's terms at the hit up to the specular power (surface sf, incoming
 * direction ray_dir, the light seen as lv; blocked: whether its shadow ray is, only read
 * where one was asked for; through: the share of the light that passes glass on it,
 * tr_shadow_transmittance, read only with TR_F_DIELECTRIC). Where a specular term
 * follows, *specular is 1 and *n_dot_h its base, max(0, n.h) clamped to [0, 1];
 * tr_add_specular adds it. */
TR_FN vec3 tr_add_light_before_power(const TrSceneRef* s, const TrHit* hit, TrSurface sf,
                                     vec3 ray_dir, TrLightView lv, int blocked, real through,
                                     vec3 sum, real* n_dot_h, int* specular) {
  *specular = 0;
  if (lv.lit == TR_LIGHT_NONE) return sum;
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  if (tr_use(s, TR_F_AMBIENT)) sum = sum + sf.albedo * lv.irradiance * m->ka;
  if (lv.lit == TR_LIGHT_AMBIENT) return sum;
  if (tr_use(s, TR_F_SHADOWS) && blocked) return sum;
  if (tr_use(s, TR_F_DIELECTRIC)) lv.irradiance = lv.irradiance * through;
  if (tr_use(s, TR_F_DIFFUSE)) sum = sum + sf.albedo * lv.irradiance * (m->kd * lv.n_dot_l);
  if (tr_use(s, TR_F_SPECULAR)) {
    vec3 view = -ray_dir;
    vec3 h = tr_normalize(lv.l + view);
    *n_dot_h = tr_clamp01(tr_dot(sf.n, h));
    *specular = 1;
  }
  return sum;
}

/* sum plus the specular term, given its power max(0, n.h)^shininess (through: as for
 * tr_add_light_before_power). */
TR_FN vec3 tr_add_specular(const TrSceneRef* s, const TrHit* hit, TrLightView lv, real through,
                           real power, vec3 sum) {
  if (tr_use(s, TR_F_DIELECTRIC)) lv.irradiance = lv.irradiance * through;
  return sum + lv.irradiance * (s->materials[hit->material].ks * power);
}

/* sum plus everything the light seen as lv adds at the hit. */
TR_FN vec3 tr_add_light(const TrSceneRef* s, const TrHit* hit, TrSurface sf, vec3 ray_dir,
                        TrLightView lv, int blocked, real through, vec3 sum) {
  real n_dot_h = TR_R(0.0);
  int specular = 0;
  sum = tr_add_light_before_power(s, hit, sf, ray_dir, lv, blocked, through, sum, &n_dot_h,
                                  &specular);
  if (!specular) return sum;
  real power = tr_pow_unit(n_dot_h, s->materials[hit->material].shininess);
  return tr_add_specular(s, hit, lv, through, power, sum);
}

/* power[r] = tr_pow_unit(n_dot_h[r], shininess of hit r's material) for the hits r < n
 * with specular[r] set, to the bit. Where all of them share a whole exponent below
 * 2^24 (one material, as most blocks see), tr_pow_unit's integer steps (tr_pow_bits)
 * run for all hits at once, the exponent's bits in the outer loop and the hits in the
 * inner one, which g++ vectorizes: the same products in the same order for each hit,
 * where one hit at a time made a chain of dependent multiplications per hit (about a
 * tenth of the demo's frame). Other exponents take tr_pow_unit hit by hit. */
TR_FN void tr_specular_powers(const TrSceneRef* s, const TrHit* hits, const int* specular,
                              const real* n_dot_h, int n, real* power) {
  real shininess = TR_R(0.0);
  int any = 0, shared = 1;
  for (int r = 0; r < n; ++r) {
    if (!specular[r]) continue;
    real e = s->materials[hits[r].material].shininess;
    shared = shared && (!any || e == shininess);
    shininess = e;
    any = 1;
  }
  if (!any) return;
  real whole = floor(shininess);
  if (!shared || shininess - whole != TR_R(0.0) || !(whole < TR_R(16777216.0))) {
    for (int r = 0; r < n; ++r)
      if (specular[r]) power[r] = tr_pow_unit(n_dot_h[r], s->materials[hits[r].material].shininess);
    return;
  }
  TR_ALIGNED(TR_LINE_BYTES) real base[TR_PACKET_MAX];
  for (int r = 0; r < n; ++r) {
    power[r] = TR_R(1.0);
    base[r] = n_dot_h[r];
  }
  tr_pow_bits(power, base, n, (int)whole);
}

/* The hit's color, tracing its shadow rays one by one, for a path of seed word seed
 * (its area lights' samples: area_light.h). tr_render_block (trace.h) adds the same
 * terms in the same order, light sample by light sample over a block's hits, with each
 * sample's shadow rays traced as one packet. */
TR_FN vec3 tr_shade(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir, unsigned int seed) {
  TrSurface sf = tr_surface(s, hit, ray_dir);
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < s->params->n_lights; ++i) {
    for (int k = 0; k < tr_light_samples(s, i); ++k) {
      vec3 light_pos = tr_light_sample_position(s, i, k, seed, hit->p);
      TrLightView lv = tr_light_view(s, hit->p, sf.n, i, light_pos);
      TrRay shadow;
      real tmax;
      int blocked = tr_light_needs_shadow_ray(s, lv, hit->shadow_p, hit->shadow_perr, hit->n,
                                              &shadow, &tmax) &&
                    tr_any_hit(s, &shadow, tmax);
      real through = tr_shadow_through(s, shadow, tmax, &blocked);
      sum = tr_add_light(s, hit, sf, ray_dir, lv, blocked, through, sum);
    }
  }
  return sum;
}
