/* Texture lookup: bilinear filtering between the four nearest texel centers, with
 * repeat wrap (u and v taken modulo 1, and the neighbour past an edge is the texel on
 * the opposite edge; an environment's rows are clamped instead). Texels are linear RGB (the host
 * decodes sRGB once), row 0 at the top: v = 1 is the image's first row, as OBJ's `vt` and every
 * image format agree. Only floor, +, -, * and compares: the same bits on both backends. */

/* u modulo 1, in [0, 1] (1 only where u is a tiny negative number and u + 1 rounds
 * up); 0 for a value that is not finite. */
TR_FN real tr_wrap01(real u) {
  real f = u - floor(u);
  return f >= TR_R(0.0) && f <= TR_R(1.0) ? f : TR_R(0.0);
}

TR_FN vec3 tr_texel(const TrSceneRef* s, TR_GLOBAL const TrTexture* t, int x, int y) {
  TR_GLOBAL const real* c = s->texels + t->first + (y * t->width + x) * 3;
  return TR_VEC3(c[0], c[1], c[2]);
}

/* Index i of a texel row or column, from -1 to n, wrapped into [0, n). */
TR_FN int tr_wrap_index(int i, int n) {
  return i < 0 ? i + n : (i >= n ? i - n : i);
}

/* Texture `index` at (u, v): u wraps around; v wraps around too, or, with clamp_rows
 * (an environment's poles: environment.h), is clamped to [0, 1] and the rows past the
 * first and last are those rows themselves. */
TR_FN vec3 tr_texture_sample(const TrSceneRef* s, int index, real u, real v, int clamp_rows) {
  TR_GLOBAL const TrTexture* t = &s->textures[index];
  int w = t->width, h = t->height;
  /* Texel (i, j) has its center at ((i + 0.5) / w, 1 - (j + 0.5) / h). */
  real x = tr_wrap01(u) * (real)w - TR_R(0.5);
  real y = (TR_R(1.0) - (clamp_rows ? tr_clamp01(v) : tr_wrap01(v))) * (real)h - TR_R(0.5);
  real fx = floor(x), fy = floor(y);
  real ax = x - fx, ay = y - fy;
  int x0 = tr_wrap_index((int)fx, w), x1 = tr_wrap_index(x0 + 1, w);
  int y0 = 0, y1 = 0;
  if (clamp_rows) {
    y0 = (int)fy < 0 ? 0 : (int)fy;
    y1 = (int)fy + 1 > h - 1 ? h - 1 : (int)fy + 1;
  } else {
    y0 = tr_wrap_index((int)fy, h);
    y1 = tr_wrap_index(y0 + 1, h);
  }
  vec3 top = tr_texel(s, t, x0, y0) * (TR_R(1.0) - ax) + tr_texel(s, t, x1, y0) * ax;
  vec3 bottom = tr_texel(s, t, x0, y1) * (TR_R(1.0) - ax) + tr_texel(s, t, x1, y1) * ax;
  return top * (TR_R(1.0) - ay) + bottom * ay;
}

/* A material's texture at the hit's (u, v): wrapping around both ways. */
TR_FN vec3 tr_texture_rgb(const TrSceneRef* s, int index, real u, real v) {
  return tr_texture_sample(s, index, u, v, 0);
}
