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

/* Is the segment from the hit to the light blocked? It starts at the hit's shadow
 * origin (the hit point, or its lift off a smooth mesh: intersect_triangle.h), offset
 * along the geometric normal by the origin's error bound. */
TR_FN int tr_light_blocked(const TrSceneRef* s, const TrHit* hit, vec3 light_pos) {
  TrRay shadow;
  shadow.o =
      tr_offset_ray_origin(hit->shadow_p, hit->shadow_perr, hit->n, light_pos - hit->shadow_p);
  vec3 to_light = light_pos - shadow.o;
  real dist = tr_length(to_light);
  if (!(dist > TR_R(0.0))) return 0;
  shadow.d = to_light * (TR_R(1.0) / dist);
  /* Stop just short of the light (1 - 2^-13 of the way), so geometry the light sits
   * on does not shadow it: a relative margin, the same at every scale. */
  return tr_any_hit(s, &shadow, dist * TR_R(0.9998779296875));
}

TR_FN vec3 tr_shade(const TrSceneRef* s, const TrHit* hit, vec3 ray_dir) {
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  vec3 albedo = TR_VEC3(m->r, m->g, m->b);
  if (tr_use(s, TR_F_TEXTURES) && m->texture >= 0)
    albedo = albedo * tr_texture_rgb(s, m->texture, hit->u, hit->v);
  vec3 n = tr_dot(hit->n, ray_dir) > TR_R(0.0) ? -hit->n : hit->n;
  if (tr_use(s, TR_F_ATTRIBUTES)) n = tr_dot(hit->ns, n) < TR_R(0.0) ? -hit->ns : hit->ns;
  vec3 view = -ray_dir;
  int use_ambient = tr_use(s, TR_F_AMBIENT);
  int use_diffuse = tr_use(s, TR_F_DIFFUSE);
  int use_specular = tr_use(s, TR_F_SPECULAR);
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < s->params->n_lights; ++i) {
    TR_GLOBAL const TrLight* light = &s->lights[i];
    vec3 light_pos = TR_VEC3(light->px, light->py, light->pz);
    vec3 to_light = light_pos - hit->p;
    real dist2 = tr_dot(to_light, to_light);
    if (!(dist2 > TR_R(0.0))) continue;
    vec3 irradiance = TR_VEC3(light->r, light->g, light->b) * (TR_R(1.0) / dist2);
    if (use_ambient) sum = sum + albedo * irradiance * m->ka;
    if (!use_diffuse && !use_specular) continue;
    vec3 l = to_light * (TR_R(1.0) / sqrt(dist2));
    real n_dot_l = tr_dot(n, l);
    if (!(n_dot_l > TR_R(0.0))) continue; /* light behind the surface: ambient only */
    if (tr_use(s, TR_F_SHADOWS) && tr_light_blocked(s, hit, light_pos)) continue;
    if (use_diffuse) sum = sum + albedo * irradiance * (m->kd * n_dot_l);
    if (use_specular) {
      vec3 h = tr_normalize(l + view);
      real n_dot_h = tr_clamp01(tr_dot(n, h));
      sum = sum + irradiance * (m->ks * tr_pow_unit(n_dot_h, m->shininess));
    }
  }
  return sum;
}
