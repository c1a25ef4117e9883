/* Adaptive anti-aliasing: a first pass of p->spp samples in every pixel, then
 * p->adaptive_spp samples in the pixels whose contrast exceeds p->adaptive_threshold.
 *
 * Criterion (Mitchell 1987's contrast test, in absolute linear units): the contrast of
 * a pixel is the largest, over the three channels, of
 *   - the range (max - min) of its own first-pass samples, which finds edges, shadow
 *     boundaries and highlights that cross the pixel, and
 *   - the difference between its first-pass mean and the first-pass mean of each of
 *     its 8 neighbours, which finds the edges that a few samples all missed on one
 *     side (a thin object, or an edge that only grazes the pixel).
 * A pixel is refined when its contrast is above the threshold. Values are linear and
 * unclamped, so the test weighs a pixel by the error it adds to the linear RMSE.
 *
 * Bits: a pixel that is not refined holds exactly what tr_render_pixel gives with
 * spp samples. A refined pixel holds exactly what tr_render_pixel gives with
 * adaptive_spp samples: the R2 sampler is progressive, so the refinement continues the
 * first pass's sum with samples spp .. adaptive_spp - 1 (the same additions in the
 * same order); the grid and stratified layouts depend on the count, so they start the
 * pixel again with the larger layout. Every step is a function of the pixel alone or
 * of first-pass sums, so both backends give the same bits.
 *
 * Per-pixel statistics of the first pass: 6 reals per pixel, row-major over the
 * statistics window of TrParams (stats_x, stats_y, stats_w, stats_h; the whole frame,
 * or a rectangle and its neighbours): the sum of the samples (r, g, b), then the range
 * of the samples (r, g, b). */

#define TR_ADAPTIVE_STATS 6

/* Pass 1: sum of the first p->spp samples of the pixel, in sample order, and the
 * per-channel range of the samples. */
TR_FN vec3 tr_adaptive_first(const TrSceneRef* s, int px, int py, vec3* range) {
  TR_GLOBAL const TrParams* p = s->params;
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  vec3 lo = sum, hi = sum;
  for (int i = 0; i < p->spp; ++i) {
    TrSample2 smp = tr_sample_position_seeded(p->sampler, p->seed, i, p->spp, px, py);
    vec3 c = tr_trace(s, tr_camera_ray(p, px, py, smp), tr_sample_seed(s, px, py, i));
    sum = sum + c;
    if (i == 0) {
      lo = c;
      hi = c;
    } else {
      lo = TR_VEC3(c.x < lo.x ? c.x : lo.x, c.y < lo.y ? c.y : lo.y, c.z < lo.z ? c.z : lo.z);
      hi = TR_VEC3(c.x > hi.x ? c.x : hi.x, c.y > hi.y ? c.y : hi.y, c.z > hi.z ? c.z : hi.z);
    }
  }
  *range = hi - lo;
  return sum;
}

/* Where pixel (px, py) of the frame keeps its statistics. */
TR_FN int tr_adaptive_stats_index(TR_GLOBAL const TrParams* p, int px, int py) {
  return ((py - p->stats_y) * p->stats_w + (px - p->stats_x)) * TR_ADAPTIVE_STATS;
}

TR_FN void tr_adaptive_store_stats(TR_GLOBAL const TrParams* p, TR_GLOBAL real* stats, int px,
                                   int py, vec3 sum, vec3 range) {
  int i = tr_adaptive_stats_index(p, px, py);
  stats[i] = sum.x;
  stats[i + 1] = sum.y;
  stats[i + 2] = sum.z;
  stats[i + 3] = range.x;
  stats[i + 4] = range.y;
  stats[i + 5] = range.z;
}

TR_FN vec3 tr_adaptive_sum(TR_GLOBAL const TrParams* p, TR_GLOBAL const real* stats, int px,
                           int py) {
  int i = tr_adaptive_stats_index(p, px, py);
  return TR_VEC3(stats[i], stats[i + 1], stats[i + 2]);
}

/* The contrast of the criterion above, from the first pass's statistics. */
TR_FN real tr_adaptive_contrast(TR_GLOBAL const TrParams* p, TR_GLOBAL const real* stats, int px,
                                int py) {
  int width = p->width, height = p->height;
  int i = tr_adaptive_stats_index(p, px, py);
  real contrast = tr_max_component(TR_VEC3(stats[i + 3], stats[i + 4], stats[i + 5]));
  real inv = TR_R(1.0) / (real)p->spp;
  vec3 mean = tr_adaptive_sum(p, stats, px, py) * inv;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      int x = px + dx, y = py + dy;
      if ((dx == 0 && dy == 0) || x < 0 || y < 0 || x >= width || y >= height) continue;
      vec3 d = tr_adaptive_sum(p, stats, x, y) * inv - mean;
      contrast = tr_max(contrast, tr_max_component(tr_abs3(d)));
    }
  }
  return contrast;
}

/* 1 when the pixel gets adaptive_spp samples. */
TR_FN int tr_adaptive_refine_flag(TR_GLOBAL const TrParams* p, TR_GLOBAL const real* stats, int px,
                                  int py) {
  return tr_adaptive_contrast(p, stats, px, py) > p->adaptive_threshold ? 1 : 0;
}

/* Pass 2: the mean of adaptive_spp samples in a refined pixel. */
TR_FN vec3 tr_adaptive_refine(const TrSceneRef* s, TR_GLOBAL const real* stats, int px, int py) {
  TR_GLOBAL const TrParams* p = s->params;
  int n = p->adaptive_spp;
  int first = 0;
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  if (p->sampler == TR_SAMPLER_R2) {
    first = p->spp;
    sum = tr_adaptive_sum(p, stats, px, py);
  }
  for (int i = first; i < n; ++i) {
    TrSample2 smp = tr_sample_position_seeded(p->sampler, p->seed, i, n, px, py);
    sum = sum + tr_trace(s, tr_camera_ray(p, px, py, smp), tr_sample_seed(s, px, py, i));
  }
  return sum * (TR_R(1.0) / (real)n);
}
