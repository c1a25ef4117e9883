/* Closest hit and any hit over the whole scene. Each primitive type is a flat array
 * walked by index; types the Features mask leaves out are dead code on both sides.
 * With TR_F_BVH, spheres and triangles are found through the flattened BVH
 * (bvh_traverse.h); planes are unbounded and always stay outside it.
 *
 * Every ray the renderer traces (camera, shadow, reflected) passes through one of the
 * two functions below, so that is where benchmarks count them (TR_COUNT_RAY, prelude.h;
 * nothing in a render or on the device). */

TR_FN int tr_closest_hit(const TrSceneRef* s, TrRay ray, real tmax, TrHit* hit) {
  int found = 0;
  TR_COUNT_RAY();
  if (tr_use(s, TR_F_BVH)) {
    found = tr_bvh_closest(s, ray, tmax, hit);
    if (found) tmax = hit->t;
  } else {
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < s->params->n_spheres; ++i)
        if (tr_intersect_sphere(&s->spheres[i], ray, tmax, hit)) {
          found = 1;
          tmax = hit->t;
        }
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = 0; i < s->params->n_triangles; ++i)
        if (tr_intersect_triangle_prepared(&s->triangles[i], ray, &tri_ray, tmax, hit)) {
          found = 1;
          tmax = hit->t;
        }
    }
  }
  if (TR_HAS(TR_F_PLANES)) {
    for (int i = 0; i < s->params->n_planes; ++i)
      if (tr_intersect_plane(&s->planes[i], ray, tmax, hit)) {
        found = 1;
        tmax = hit->t;
      }
  }
  return found;
}

/* Is anything in (0, tmax) along the ray? Stops at the first hit. */
TR_FN int tr_any_hit(const TrSceneRef* s, TrRay ray, real tmax) {
  TrHit scratch = tr_no_hit();
  TR_COUNT_RAY();
  if (tr_use(s, TR_F_BVH)) {
    if (tr_bvh_any(s, ray, tmax)) return 1;
  } else {
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < s->params->n_spheres; ++i)
        if (tr_intersect_sphere(&s->spheres[i], ray, tmax, &scratch)) return 1;
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = 0; i < s->params->n_triangles; ++i)
        if (tr_intersect_triangle_prepared(&s->triangles[i], ray, &tri_ray, tmax, &scratch))
          return 1;
    }
  }
  if (TR_HAS(TR_F_PLANES)) {
    for (int i = 0; i < s->params->n_planes; ++i)
      if (tr_intersect_plane(&s->planes[i], ray, tmax, &scratch)) return 1;
  }
  return 0;
}
