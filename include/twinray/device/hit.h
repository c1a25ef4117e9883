/* A hit record with every field set: no path reads an unset value. */
TR_FN TrHit tr_no_hit(void) {
  TrHit h;
  h.t = TR_R(INFINITY);
  h.p = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  h.perr = h.p;
  h.n = h.p;
  h.ns = h.p;
  h.shadow_p = h.p;
  h.shadow_perr = h.p;
  h.u = TR_R(0.0);
  h.v = TR_R(0.0);
  h.material = -1;
  h.object = -1;
  return h;
}
