/* Sub-pixel sample positions, from integer arithmetic on the pixel, the sample index
 * and a seed only, so both sides place every sample at the same bits.
 *
 * Every position is a 24-bit fixed-point number k * 2^-24 with 0 <= k < 2^24, built
 * with 32-bit unsigned integer arithmetic (wrapping multiplication is the same on both
 * sides) and converted with one exact multiplication. So a position is the same real in
 * float and in double, and always strictly inside the pixel: [0, 1 - 2^-24].
 *
 *   TR_SAMPLER_GRID        regular grid: ceil(sqrt(spp)) columns, as many rows as
 *                          needed, the centers of the cells in row-major order
 *                          (spp = 1 gives the pixel center). Deterministic; aliases.
 *   TR_SAMPLER_STRATIFIED  the same cells, one uniformly jittered sample in each
 *                          (jitter from a hash of pixel, sample index and seed).
 *   TR_SAMPLER_R2          the R2 low-discrepancy sequence (Roberts 2018: additive
 *                          recurrence on the plastic number, x_n = frac(1/2 + n a)),
 *                          toroidally shifted per pixel by a hash of pixel and seed
 *                          (Cranley-Patterson rotation) so neighbouring pixels do not
 *                          share one pattern. Progressive: the first N samples of any
 *                          larger count are the N-sample set, which adaptive sampling
 *                          uses (device/adaptive.h).
 *
 * Grid and stratified place at most 256 x 256 cells: spp <= 65536 (Limits::max_spp),
 * which keeps every shifted cell index below 2^32. */

#define TR_SAMPLER_GRID 0
#define TR_SAMPLER_STRATIFIED 1
#define TR_SAMPLER_R2 2

/* lowbias32 (C. Wellons' integer hash, bias 0.17): a bijection on 32-bit words. */
TR_FN unsigned int tr_hash_u32(unsigned int x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

/* One 32-bit word per (pixel, seed). */
TR_FN unsigned int tr_pixel_hash(int px, int py, int seed) {
  unsigned int h = tr_hash_u32((unsigned int)seed + 0x9e3779b9u);
  h = tr_hash_u32(h ^ (unsigned int)py);
  return tr_hash_u32(h + (unsigned int)px);
}

/* The top 24 bits of a word as a real in [0, 1 - 2^-24]; exact in float and double. */
TR_FN real tr_fixed24(unsigned int word) {
  return (real)(int)(word >> 8) * TR_R(5.9604644775390625e-08); /* 2^-24 */
}

/* Columns of the grid/stratified layout: ceil(sqrt(spp)). */
TR_FN int tr_grid_columns(int spp) {
  int cols = 1;
  while (cols * cols < spp) ++cols;
  return cols;
}

/* Regular grid: the center of cell (index % cols, index / cols). */
TR_FN TrSample2 tr_sample_grid(int index, int spp) {
  int cols = tr_grid_columns(spp);
  int rows = (spp + cols - 1) / cols;
  unsigned int col = (unsigned int)(index % cols), row = (unsigned int)(index / cols);
  TrSample2 smp;
  /* (2 col + 1) / (2 cols) in units of 2^-24; 511 << 23 < 2^32 */
  smp.x = tr_fixed24((((2u * col + 1u) << 23) / (unsigned int)cols) << 8);
  smp.y = tr_fixed24((((2u * row + 1u) << 23) / (unsigned int)rows) << 8);
  return smp;
}

/* Stratified (jittered): cell (index % cols, index / cols), a uniform offset inside it
 * from the 24-bit jitter words jx, jy: (col + jx 2^-24) / cols, in 2^-24 units. */
TR_FN TrSample2 tr_sample_stratified(int index, int spp, unsigned int pixel_hash) {
  int cols = tr_grid_columns(spp);
  int rows = (spp + cols - 1) / cols;
  unsigned int col = (unsigned int)(index % cols), row = (unsigned int)(index / cols);
  unsigned int jx = tr_hash_u32(pixel_hash + (unsigned int)index);
  unsigned int jy = tr_hash_u32(jx ^ 0x68e31da4u);
  TrSample2 smp;
  /* col <= 255, so (col << 24) + (jx >> 8) < 2^32 */
  smp.x = tr_fixed24((((col << 24) + (jx >> 8)) / (unsigned int)cols) << 8);
  smp.y = tr_fixed24((((row << 24) + (jy >> 8)) / (unsigned int)rows) << 8);
  return smp;
}

/* R2: 2^32 (1/2 + n a1, 1/2 + n a2) mod 2^32 with a1 = 1/g, a2 = 1/g^2, g the plastic
 * number (g^3 = g + 1), as 32-bit fixed-point constants, plus the pixel's shift. */
TR_FN TrSample2 tr_sample_r2(int index, unsigned int pixel_hash) {
  unsigned int n = (unsigned int)index;
  unsigned int shift_y = tr_hash_u32(pixel_hash ^ 0x3c6ef372u);
  TrSample2 smp;
  smp.x = tr_fixed24(0x80000000u + n * 3242174889u + pixel_hash);
  smp.y = tr_fixed24(0x80000000u + n * 2447445414u + shift_y);
  return smp;
}

/* Whether the sampler places a sample differently in each pixel (the grid does not:
 * its positions depend on the sample index alone). */
TR_FN int tr_sampler_per_pixel(int sampler) {
  return sampler == TR_SAMPLER_STRATIFIED || sampler == TR_SAMPLER_R2;
}

/* Position of sample `index` of `spp` in pixel (px, py), for any sampler. */
TR_FN TrSample2 tr_sample_position_seeded(int sampler, int seed, int index, int spp, int px,
                                          int py) {
  if (!tr_sampler_per_pixel(sampler)) return tr_sample_grid(index, spp);
  unsigned int pixel_hash = tr_pixel_hash(px, py, seed);
  if (sampler == TR_SAMPLER_STRATIFIED) return tr_sample_stratified(index, spp, pixel_hash);
  return tr_sample_r2(index, pixel_hash);
}

/* The same with seed 0. */
TR_FN TrSample2 tr_sample_position(int sampler, int index, int spp, int px, int py) {
  return tr_sample_position_seeded(sampler, 0, index, spp, px, py);
}
