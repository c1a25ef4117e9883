/* A hit record with every field set: no path reads an unset value. Written in place:
 * copied out of a returned temporary into each missed ray's slot of a packet, clang
 * wrote the temporary with two 64-byte stores and read it back with loads that straddle
 * them, a store-forwarding stall on every miss (most of tr_closest_hit_packet's own
 * time on mesh_1e4, docs/performance.md). */
TR_FN_INLINE void tr_set_no_hit(TrHit* h) {
  h->t = TR_R(INFINITY);
  h->p = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  h->perr = h->p;
  h->n = h->p;
  h->ns = h->p;
  h->shadow_p = h->p;
  h->shadow_perr = h->p;
  h->u = TR_R(0.0);
  h->v = TR_R(0.0);
  h->material = -1;
  h->object = -1;
}

TR_FN TrHit tr_no_hit(void) {
  TrHit h;
  tr_set_no_hit(&h);
  return h;
}
