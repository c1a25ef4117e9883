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

/* A primitive's hit record with every field set, each stored once from its value: the
 * shading normal is n, shadow rays start at p, no texture coordinates (a triangle's
 * attributes may change these after). Stored, never read back: a copy such as ns = n
 * read from the record made g++ load the normal across the end of the wider store it
 * had merged the fields before it into, a store-forwarding stall on every hit
 * (tr_record_hit took 19% of g++'s samples on the demo frame, 7% of clang's). */
TR_FN_INLINE void tr_set_hit(TrHit* h, real t, vec3 p, vec3 perr, vec3 n, int material,
                             int object) {
  h->t = t;
  h->p = p;
  h->perr = perr;
  h->n = n;
  h->ns = n;
  h->shadow_p = p;
  h->shadow_perr = perr;
  h->u = TR_R(0.0);
  h->v = TR_R(0.0);
  h->material = material;
  h->object = object;
}
