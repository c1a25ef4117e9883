/* Blinn-Phong shading with hard shadows (the original assignment's formulas), in linear RGB. For
 * each point light, with C the material color and E = intensity x color / d^2 the light's
 * irradiance at distance d (inverse-square law):
 *   ambient  = ka C E
 *   diffuse  = kd C E max(0, n.l)
 *   specular = ks E max(0, n.h)^shininess       h = normalize(l + v)
 * A point whose shadow ray toward the light is blocked gets the ambient term only.
 * n is the shading normal (the geometric one, or a mesh's interpolated vertex normal)
 * turned to the side of the geometric normal that faces the incoming ray, so
 * triangles and planes are lit from whichever side is seen. C is the material color,
 * times its texture at the hit's uv where it has one (texture.h). Each term and the
 * shadow rays can be switched off (Features mask). */

/* The shadow ray from the hit toward the light and the distance it must stay clear
 * for; 0 where there is none (the offset origin is at the light). It starts at the
 * hit's shadow origin (the hit point, or its lift off a smooth mesh:
 * intersect_triangle.h), offset along the geometric normal by the origin's error
 * bound. */
TR_FN int tr_shadow_ray(const TrHit* hit, vec3 light_pos, TrRay* shadow, real* tmax) {
  shadow->o =
      tr_offset_ray_origin(hit->shadow_p, hit->shadow_perr, hit->n, light_pos - hit->shadow_p);
  vec3 to_light = light_pos - shadow->o;
  real dist = tr_length(to_light);
  if (!(dist > TR_R(0.0))) return 0;
  shadow->d = to_light * (TR_R(1.0) / dist);
  /* Stop just short of the light (1 - 2^-13 of the way), so geometry the light sits
   * on does not shadow it: a relative margin, the same at every scale. */
  *tmax = dist * TR_R(0.9998779296875);
  return 1;
}

/* Is the segment from the hit to the light blocked? */
TR_FN int tr_light_blocked(const TrSceneRef* s, const TrHit* hit, vec3 light_pos) {
  TrRay shadow;
  real tmax;
  if (!tr_shadow_ray(hit, light_pos, &shadow, &tmax)) return 0;
  return tr_any_hit(s, &shadow, tmax);
}

/* The normal the hit is shaded with: the shading normal, turned to the side of the
 * geometric normal that faces the incoming ray. */
TR_FN vec3 tr_facing_normal(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir) {
  vec3 n = tr_dot(hit->n, ray_dir) > TR_R(0.0) ? -hit->n : hit->n;
  if (tr_use(s, TR_F_ATTRIBUTES)) n = tr_dot(hit->ns, n) < TR_R(0.0) ? -hit->ns : hit->ns;
  return n;
}

/* Light i as seen from the hit with facing normal n. */
TR_FN TrLightView tr_light_view(const TrSceneRef* s, const TrHit* hit, vec3 n, int i) {
  TR_GLOBAL const TrLight* light = &s->lights[i];
  TrLightView lv;
  lv.pos = TR_VEC3(light->px, light->py, light->pz);
  lv.lit = TR_LIGHT_NONE;
  vec3 to_light = lv.pos - hit->p;
  real dist2 = tr_dot(to_light, to_light);
  if (!(dist2 > TR_R(0.0))) return lv;
  lv.irradiance = TR_VEC3(light->r, light->g, light->b) * (TR_R(1.0) / dist2);
  lv.lit = TR_LIGHT_AMBIENT;
  if (!tr_use(s, TR_F_DIFFUSE) && !tr_use(s, TR_F_SPECULAR)) return lv;
  lv.l = to_light * (TR_R(1.0) / sqrt(dist2));
  lv.n_dot_l = tr_dot(n, lv.l);
  if (lv.n_dot_l > TR_R(0.0)) lv.lit = TR_LIGHT_ALL; /* else: behind the surface */
  return lv;
}

/* Whether shading the hit asks if light i is blocked (then *shadow and *tmax say what
 * to trace): shadows on, the light in front of the surface, and a term it would add. */
TR_FN int tr_shading_needs_shadow_ray(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir, int i,
                                      TrRay* shadow, real* tmax) {
  if (!tr_use(s, TR_F_SHADOWS)) return 0;
  TrLightView lv = tr_light_view(s, hit, tr_facing_normal(s, hit, ray_dir), i);
  return lv.lit == TR_LIGHT_ALL && tr_shadow_ray(hit, lv.pos, shadow, tmax);
}

/* The hit's color. Lights below n_known have their shadow tests answered in bit i of
 * `blocked` (traced beforehand, many rays at once: trace.h); the others are traced
 * here. */
TR_FN vec3 tr_shade_known(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir, unsigned blocked,
                          int n_known) {
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  vec3 albedo = TR_VEC3(m->r, m->g, m->b);
  if (tr_use(s, TR_F_TEXTURES) && m->texture >= 0)
    albedo = albedo * tr_texture_rgb(s, m->texture, hit->u, hit->v);
  vec3 n = tr_facing_normal(s, hit, ray_dir);
  vec3 view = -ray_dir;
  int use_ambient = tr_use(s, TR_F_AMBIENT);
  int use_diffuse = tr_use(s, TR_F_DIFFUSE);
  int use_specular = tr_use(s, TR_F_SPECULAR);
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < s->params->n_lights; ++i) {
    TrLightView lv = tr_light_view(s, hit, n, i);
    if (lv.lit == TR_LIGHT_NONE) continue;
    if (use_ambient) sum = sum + albedo * lv.irradiance * m->ka;
    if (lv.lit == TR_LIGHT_AMBIENT) continue;
    if (tr_use(s, TR_F_SHADOWS)) {
      int is_blocked = i < n_known ? (int)((blocked >> i) & 1u) : tr_light_blocked(s, hit, lv.pos);
      if (is_blocked) continue;
    }
    if (use_diffuse) sum = sum + albedo * lv.irradiance * (m->kd * lv.n_dot_l);
    if (use_specular) {
      vec3 h = tr_normalize(lv.l + view);
      real n_dot_h = tr_clamp01(tr_dot(n, h));
      sum = sum + lv.irradiance * (m->ks * tr_pow_unit(n_dot_h, m->shininess));
    }
  }
  return sum;
}

TR_FN vec3 tr_shade(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir) {
  return tr_shade_known(s, hit, ray_dir, 0u, 0);
}
