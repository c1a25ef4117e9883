/* Sub-pixel sample positions, from integer arithmetic on the sample index only, so
 * both sides place every sample at the same bits. */

#define TR_SAMPLER_GRID 0

/* Regular grid: ceil(sqrt(spp)) columns, as many rows as needed, sample centers of
 * the cells in row-major order. spp = 1 gives the pixel center. */
TR_FN TrSample2 tr_sample_grid(int index, int spp) {
  int cols = 1;
  while (cols * cols < spp) ++cols;
  int rows = (spp + cols - 1) / cols;
  TrSample2 smp;
  smp.x = ((real)(index % cols) + TR_R(0.5)) / (real)cols;
  smp.y = ((real)(index / cols) + TR_R(0.5)) / (real)rows;
  return smp;
}

TR_FN TrSample2 tr_sample_position(int sampler, int index, int spp, int px, int py) {
  (void)sampler;
  (void)px;
  (void)py;
  return tr_sample_grid(index, spp);
}
