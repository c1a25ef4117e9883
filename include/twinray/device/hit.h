/* A hit record with every field set: no path reads an unset value. */
TR_FN TrHit tr_no_hit(void) {
  TrHit h;
  h.t = TR_R(INFINITY);
  h.p = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  h.perr = h.p;
  h.n = h.p;
  h.material = -1;
  h.object = -1;
  return h;
}
