/* Closest hit and any hit over the whole scene. Each primitive type is a flat array
 * walked by index; types the Features mask leaves out are dead code on both sides.
 * With TR_F_BVH, spheres and triangles are found through the flattened BVH
 * (bvh_traverse.h); planes are unbounded and always stay outside it.
 *
 * Every ray the renderer traces (camera, shadow, reflected) passes through one of the
 * two functions below, so that is where benchmarks count them (TR_COUNT_RAY, prelude.h;
 * nothing in a render or on the device). */

/* The hit record of the nearest hit, made once per ray from its (t, primitive). The
 * shading normal, shadow origin and uv are the geometric ones unless a triangle's
 * attributes say otherwise. Each primitive's record sets every field once
 * (tr_set_hit), in place: no field is read back to copy it, and no local record is
 * copied out (g++ read such a copy with wide loads across the narrower stores that
 * had just made it, a store-forwarding stall on every hit). */
TR_FN void tr_record_hit(const TrSceneRef* s, TrRay world_ray, TrNearest nearest, TrHit* hit) {
  /* A hit in an instance is recorded in its asset's space, then brought to the world. */
  int in_instance = TR_HAS(TR_F_INSTANCES) && nearest.instance >= 0;
  TrRay ray = in_instance ? tr_instance_ray(&s->instances[nearest.instance], world_ray) : world_ray;
  int n_spheres = s->params->n_spheres;
  int n_bounded = n_spheres + s->params->n_triangles;
  int prim = nearest.prim;
  int triangle = -1;
  vec3 bary = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres) {
    tr_sphere_record(&s->spheres[prim], ray, nearest.t, hit);
  } else if (TR_HAS(TR_F_TRIANGLES) && prim < n_bounded) {
    TrTriangleRay tri_ray = tr_triangle_ray(ray);
    triangle = prim - n_spheres;
    tr_triangle_record(&s->triangles[triangle], ray, &tri_ray, nearest.t, hit, &bary);
  } else if (TR_HAS(TR_F_PLANES)) {
    tr_plane_record(&s->planes[prim - n_bounded], ray, nearest.t, hit);
  } else {
    tr_set_no_hit(hit); /* no such primitive (never for a hit found): every field set */
  }
  if (tr_use(s, TR_F_ATTRIBUTES) && triangle >= 0)
    tr_triangle_attributes(&s->triangle_attrs[triangle], &s->triangles[triangle], bary, ray.d, hit);
  if (in_instance) tr_instance_hit_to_world(&s->instances[nearest.instance], hit);
}

/* The end of a closest-hit query once the BVH (or the flat arrays) has been searched:
 * the planes, which stay outside the BVH, then the record of the nearest hit. */
TR_FN_INLINE int tr_closest_hit_finish(const TrSceneRef* s, TrRay ray, TrNearest nearest,
                                       TrHit* hit) {
  if (TR_HAS(TR_F_PLANES)) {
    int n_bounded = s->params->n_spheres + s->params->n_triangles;
    for (int i = 0; i < s->params->n_planes; ++i)
      tr_offer_hit_in(s, &nearest, tr_plane_t(&s->planes[i], ray), n_bounded + i, -1);
  }
  if (nearest.prim < 0) return 0;
  tr_record_hit(s, ray, nearest, hit);
  return 1;
}

/* The nearest hit in (0, tmax): the smallest (t, primitive id), see tr_offer_hit.
 * Both entry points take the ray by pointer: passed by value, g++ stores the caller's
 * ray field by field and reloads it in 16-byte pieces for the call, a store-forwarding
 * stall on every ray (up to a tenth of a frame, docs/performance.md). */
TR_FN_OUTLINE int tr_closest_hit(const TrSceneRef* s, const TrRay* ray_in, real tmax, TrHit* hit) {
  TrRay ray = *ray_in;
  TrNearest nearest = tr_nearest(tmax, -1);
  int n_spheres = s->params->n_spheres;
  TR_COUNT_RAY();
  if (tr_use(s, TR_F_BVH)) {
    tr_bvh_walk(s, ray, &nearest, 0);
  } else {
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < n_spheres; ++i)
        tr_offer_hit(&nearest, tr_sphere_t(&s->spheres[i], ray), i);
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = 0; i < s->params->n_triangles; ++i)
        tr_offer_hit(&nearest, tr_triangle_t(&s->triangles[i], ray, &tri_ray), n_spheres + i);
    }
  }
  return tr_closest_hit_finish(s, ray, nearest, hit);
}

/* Does a plane (outside the BVH) lie in (0, tmax) along the ray? */
TR_FN_INLINE int tr_any_plane_hit(const TrSceneRef* s, TrRay ray, real tmax) {
  if (TR_HAS(TR_F_PLANES)) {
    for (int i = 0; i < s->params->n_planes; ++i) {
      real t = tr_plane_t(&s->planes[i], ray);
      if (t > TR_R(0.0) && t < tmax) return 1;
    }
  }
  return 0;
}

/* Is anything in (0, tmax) along the ray? Stops at the first hit and makes no record. */
TR_FN_OUTLINE int tr_any_hit(const TrSceneRef* s, const TrRay* ray_in, real tmax) {
  TrRay ray = *ray_in;
  TR_COUNT_RAY();
  if (tr_use(s, TR_F_BVH)) {
    TrNearest limit = tr_nearest(tmax, -1);
    if (tr_bvh_walk(s, ray, &limit, 1)) return 1;
  } else {
    if (TR_HAS(TR_F_SPHERES)) {
      for (int i = 0; i < s->params->n_spheres; ++i) {
        real t = tr_sphere_t(&s->spheres[i], ray);
        if (t > TR_R(0.0) && t < tmax) return 1;
      }
    }
    if (TR_HAS(TR_F_TRIANGLES)) {
      TrTriangleRay tri_ray = tr_triangle_ray(ray);
      for (int i = 0; i < s->params->n_triangles; ++i) {
        real t = tr_triangle_t(&s->triangles[i], ray, &tri_ray);
        if (t > TR_R(0.0) && t < tmax) return 1;
      }
    }
  }
  return tr_any_plane_hit(s, ray, tmax);
}

/* The planes (outside the BVH) offered to the packet's rays after its BVH walk
 * (tr_packet_begin has run), a ray per SIMD lane: closest hit or any hit as in
 * tr_packet_offer. */
TR_FN_INLINE void tr_packet_planes(const TrSceneRef* s, TrRayPacket* pk, int any_hit) {
  if (!TR_HAS(TR_F_PLANES)) return;
  int n_bounded = s->params->n_spheres + s->params->n_triangles;
  for (int i = 0; i < s->params->n_planes; ++i) {
    vec3 normal = tr_plane_normal(&s->planes[i]), point = tr_plane_point(&s->planes[i]);
    TR_LANE_LOOP
    for (int r = 0; r < pk->n; ++r) {
      real t;
      int hit = tr_plane_hit_at(normal, point, tr_packet_ray(pk, r), &t);
      tr_packet_offer(pk, r, hit, t, n_bounded + i, any_hit);
    }
  }
}

/* tr_closest_hit for the packet's rays pk->ray[0 .. n), each in (0, inf): found[r] and
 * hit[r]. With a BVH, the packet is walked as one where its rays are coherent
 * (bvh_packet.h); the answers are those of tr_closest_hit, ray by ray. */
TR_FN_OUTLINE void tr_closest_hit_packet(const TrSceneRef* s, TrRayPacket* pk, TrHit* hit,
                                         int* found) {
  if (!tr_use(s, TR_F_BVH) || tr_use(s, TR_F_INSTANCES)) {
    for (int r = 0; r < pk->n; ++r) {
      tr_set_no_hit(&hit[r]);
      found[r] = tr_closest_hit(s, &pk->ray[r], TR_R(INFINITY), &hit[r]);
    }
    return;
  }
  for (int r = 0; r < pk->n; ++r) {
    pk->t[r] = TR_R(INFINITY);
    pk->prim[r] = -1;
  }
  tr_packet_bvh(s, pk, tr_packet_begin(pk), 0);
  tr_packet_planes(s, pk, 0);
  for (int r = 0; r < pk->n; ++r) {
    TrNearest nearest = tr_nearest(pk->t[r], pk->prim[r]);
    TR_COUNT_RAY();
    found[r] = nearest.prim >= 0;
    if (found[r])
      tr_record_hit(s, pk->ray[r], nearest, &hit[r]); /* writes every field */
    else
      tr_set_no_hit(&hit[r]);
  }
}

/* tr_any_hit for the packet's rays, ray r's tmax in pk->t[r]: blocked[r]. */
TR_FN_OUTLINE void tr_any_hit_packet(const TrSceneRef* s, TrRayPacket* pk, int* blocked) {
  if (!tr_use(s, TR_F_BVH) || tr_use(s, TR_F_INSTANCES)) {
    for (int r = 0; r < pk->n; ++r) blocked[r] = tr_any_hit(s, &pk->ray[r], pk->t[r]);
    return;
  }
  for (int r = 0; r < pk->n; ++r) pk->prim[r] = -1;
  int coherent = tr_packet_begin(pk); /* also the arrays tr_packet_planes reads */
  tr_packet_bvh(s, pk, coherent, 1);
  tr_packet_planes(s, pk, 1);
  for (int r = 0; r < pk->n; ++r) {
    TR_COUNT_RAY();
    blocked[r] = pk->t[r] < TR_R(0.0);
  }
}
