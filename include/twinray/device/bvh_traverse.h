/* Iterative BVH traversal with a small fixed stack (no recursion: OpenCL C has none).
 * Nodes are flat and index-based (types.h TrBvhNode), so the same walk runs on both
 * sides. Box test: the slab method with the far distance scaled by 1 + 2 gamma(3), so
 * rounding never culls a box the ray touches (pbrt-v4 Bounds3::IntersectP). */

#define TR_BVH_STACK_SIZE 64

/* BVH primitive ids: spheres first, then triangles. */
TR_FN int tr_intersect_primitive(const TrSceneRef* s, int prim, TrRay ray, real tmax, TrHit* hit) {
  int n_spheres = s->params->n_spheres;
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres)
    return tr_intersect_sphere(&s->spheres[prim], ray, tmax, hit);
  if (TR_HAS(TR_F_TRIANGLES))
    return tr_intersect_triangle(&s->triangles[prim - n_spheres], ray, tmax, hit);
  return 0;
}

TR_FN int tr_ray_hits_box(TR_GLOBAL const TrBvhNode* node, vec3 o, vec3 inv_d, real tmax) {
  real t0 = TR_R(0.0), t1 = tmax;
  real grow = TR_R(1.0) + TR_R(2.0) * tr_gamma(3);
  real tn, tf, tmp;
  tn = (node->min_x - o.x) * inv_d.x;
  tf = (node->max_x - o.x) * inv_d.x;
  if (tn > tf) {
    tmp = tn;
    tn = tf;
    tf = tmp;
  }
  tf = tf * grow;
  t0 = tn > t0 ? tn : t0;
  t1 = tf < t1 ? tf : t1;
  if (t0 > t1) return 0;
  tn = (node->min_y - o.y) * inv_d.y;
  tf = (node->max_y - o.y) * inv_d.y;
  if (tn > tf) {
    tmp = tn;
    tn = tf;
    tf = tmp;
  }
  tf = tf * grow;
  t0 = tn > t0 ? tn : t0;
  t1 = tf < t1 ? tf : t1;
  if (t0 > t1) return 0;
  tn = (node->min_z - o.z) * inv_d.z;
  tf = (node->max_z - o.z) * inv_d.z;
  if (tn > tf) {
    tmp = tn;
    tn = tf;
    tf = tmp;
  }
  tf = tf * grow;
  t0 = tn > t0 ? tn : t0;
  t1 = tf < t1 ? tf : t1;
  return t0 <= t1;
}

/* Walks the BVH; any_hit != 0 stops at the first hit found. Returns whether one was. */
TR_FN int tr_bvh_walk(const TrSceneRef* s, TrRay ray, real tmax, TrHit* hit, int any_hit) {
  if (s->params->n_bvh_nodes <= 0) return 0;
  vec3 inv_d = TR_VEC3(TR_R(1.0) / ray.d.x, TR_R(1.0) / ray.d.y, TR_R(1.0) / ray.d.z);
  int stack[TR_BVH_STACK_SIZE];
  int top = 0;
  int found = 0;
  stack[top++] = 0;
  while (top > 0) {
    int index = stack[--top];
    TR_GLOBAL const TrBvhNode* node = &s->bvh_nodes[index];
    if (!tr_ray_hits_box(node, ray.o, inv_d, tmax)) continue;
    if (node->count > 0) {
      for (int i = 0; i < node->count; ++i) {
        if (tr_intersect_primitive(s, s->bvh_prims[node->first + i], ray, tmax, hit)) {
          found = 1;
          tmax = hit->t;
          if (any_hit) return 1;
        }
      }
    } else if (top + 2 <= TR_BVH_STACK_SIZE) {
      /* Visit the child nearer along the ray first: push it last. */
      int left = node->first;
      int near_first = tr_component(ray.d, -node->count) >= TR_R(0.0); /* split axis */
      if (near_first) {
        stack[top++] = left + 1;
        stack[top++] = left;
      } else {
        stack[top++] = left;
        stack[top++] = left + 1;
      }
    }
  }
  return found;
}

TR_FN int tr_bvh_closest(const TrSceneRef* s, TrRay ray, real tmax, TrHit* hit) {
  return tr_bvh_walk(s, ray, tmax, hit, 0);
}

TR_FN int tr_bvh_any(const TrSceneRef* s, TrRay ray, real tmax) {
  TrHit scratch = tr_no_hit();
  return tr_bvh_walk(s, ray, tmax, &scratch, 1);
}
