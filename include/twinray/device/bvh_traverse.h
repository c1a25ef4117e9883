/* Iterative BVH traversal with a small fixed stack (no recursion: OpenCL C has none).
 * Nodes are flat and index-based (types.h TrBvhNode), so the same walk runs on both
 * sides and visits the same nodes in the same order. Box test: the slab method with
 * the far distances scaled by 1 + 2 gamma(3), so rounding never culls a box the ray
 * touches (pbrt-v4 Bounds3::IntersectP). */

#define TR_BVH_STACK_SIZE 64

/* BVH primitive ids: spheres first, then triangles. Only the distance: see TrNearest. */
TR_FN_INLINE real tr_primitive_t(const TrSceneRef* s, int prim, TrRay ray,
                                 const TrTriangleRay* tri_ray) {
  int n_spheres = s->params->n_spheres;
  if (TR_HAS(TR_F_SPHERES) && prim < n_spheres) return tr_sphere_t(&s->spheres[prim], ray);
  if (TR_HAS(TR_F_TRIANGLES)) return tr_triangle_t(&s->triangles[prim - n_spheres], ray, tri_ray);
  return TR_R(0.0);
}

/* Keeps (t, prim) if it comes before the nearest hit so far in the order of t, then
 * primitive id. The order is total, so the nearest hit does not depend on the order
 * primitives are tested in: neither the BVH's shape and width nor the order children
 * are visited can change a pixel, on any backend. (Ties are real: a ray through an
 * edge two triangles share hits both at the same t.) */
TR_FN_INLINE void tr_offer_hit(TrNearest* nearest, real t, int prim) {
  if (t > TR_R(0.0) && (t < nearest->t || (t == nearest->t && prim < nearest->prim))) {
    nearest->t = t;
    nearest->prim = prim;
  }
}

/* The box test's view of a ray; computed once per query. */
TR_FN_INLINE TrBoxRay tr_box_ray(TrRay ray) {
  TrBoxRay br;
  br.o = ray.o;
  br.inv_d = TR_VEC3(TR_R(1.0) / ray.d.x, TR_R(1.0) / ray.d.y, TR_R(1.0) / ray.d.z);
  br.inv_d_far = br.inv_d * (TR_R(1.0) + TR_R(2.0) * tr_gamma(3));
  br.near_x = br.inv_d.x < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X;
  br.near_y = (br.inv_d.y < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X) + 1;
  br.near_z = (br.inv_d.z < TR_R(0.0) ? TR_BVH_MAX_X : TR_BVH_MIN_X) + 2;
  br.far_x = br.inv_d.x < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X;
  br.far_y = (br.inv_d.y < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X) + 1;
  br.far_z = (br.inv_d.z < TR_R(0.0) ? TR_BVH_MIN_X : TR_BVH_MAX_X) + 2;
  return br;
}

/* Slab test of one box; on a hit, *t_entry is where the ray enters it (0 if it starts
 * inside). The near and far planes of each slab are chosen by the sign of the inverse
 * direction, once per ray (Williams, Barrus, Morley, Shirley, "An Efficient and Robust
 * Ray-Box Intersection Algorithm", JGT 2005), so there is no swap and no branch.
 * Rounding must never cull a box that holds a primitive the primitive tests would
 * report: the far distances are grown by 1 + 2 gamma(3), the bound pbrt-v4's
 * Bounds3::IntersectP applies to each far distance, but folded into a padded reciprocal
 * computed once per ray, as Ize does ("Robust BVH Ray Traversal", JCGT 2(2), 2013):
 * the same four roundings, one multiplication fewer per slab. The ray's own end,
 * tmax_grown, is grown by the caller, and the builder pads every box (pack/bvh.hpp). A
 * slab distance that is NaN (0 * inf: the origin on a face of a box the ray runs
 * parallel to) fails its compare below and narrows nothing. */
TR_FN_INLINE int tr_ray_hits_box(TR_GLOBAL const TrBvhNode* node, const TrBoxRay* br,
                                 real tmax_grown, real* t_entry) {
  real near_x = (node->bounds[br->near_x] - br->o.x) * br->inv_d.x;
  real near_y = (node->bounds[br->near_y] - br->o.y) * br->inv_d.y;
  real near_z = (node->bounds[br->near_z] - br->o.z) * br->inv_d.z;
  real far_x = (node->bounds[br->far_x] - br->o.x) * br->inv_d_far.x;
  real far_y = (node->bounds[br->far_y] - br->o.y) * br->inv_d_far.y;
  real far_z = (node->bounds[br->far_z] - br->o.z) * br->inv_d_far.z;
  real t0 = TR_R(0.0), t1 = tmax_grown;
  t0 = near_x > t0 ? near_x : t0;
  t0 = near_y > t0 ? near_y : t0;
  t0 = near_z > t0 ? near_z : t0;
  t1 = far_x < t1 ? far_x : t1;
  t1 = far_y < t1 ? far_y : t1;
  t1 = far_z < t1 ? far_z : t1;
  *t_entry = t0;
  return t0 <= t1;
}

/* Walks the BVH. Closest hit (any_hit = 0): offers every primitive in the leaves it
 * reaches to *nearest and returns whether there is one. Any hit: returns 1 at the first
 * primitive in (0, nearest->t), computing nothing else.
 * At an inner node both children's boxes are tested: the walk goes on into the one the
 * ray enters first and pushes the other with its entry distance, which is checked
 * again when it is popped, against the nearest hit found by then (a box entered beyond
 * it cannot hold a nearer hit; one entered at exactly that distance can hold a tie,
 * and is kept). The stack holds at most one entry per level, and the builder caps the
 * depth (pack/bvh.hpp kMaxDepth < TR_BVH_STACK_SIZE), so it never overflows. */
TR_FN int tr_bvh_walk(const TrSceneRef* s, TrRay ray, TrNearest* nearest, int any_hit) {
  if (s->params->n_bvh_nodes <= 0) return 0;
  TrBoxRay box_ray = tr_box_ray(ray);
  real grow = TR_R(1.0) + TR_R(2.0) * tr_gamma(3);
  int stack_node[TR_BVH_STACK_SIZE];
  real stack_t[TR_BVH_STACK_SIZE];
  int top = 0;
  real t_root;
  if (!tr_ray_hits_box(&s->bvh_nodes[0], &box_ray, nearest->t * grow, &t_root)) return 0;
  TrTriangleRay tri_ray = tr_triangle_ray(ray);
  int index = 0;
  for (;;) {
    TR_GLOBAL const TrBvhNode* node = &s->bvh_nodes[index];
    int next = -1;
    if (node->count > 0) {
      for (int i = 0; i < node->count; ++i) {
        int prim = s->bvh_prims[node->first + i];
        real t = tr_primitive_t(s, prim, ray, &tri_ray);
        if (any_hit) {
          if (t > TR_R(0.0) && t < nearest->t) return 1;
        } else {
          tr_offer_hit(nearest, t, prim);
        }
      }
    } else {
      int left = node->first;
      real t_left, t_right;
      real tmax_grown = nearest->t * grow;
      int hit_left = tr_ray_hits_box(&s->bvh_nodes[left], &box_ray, tmax_grown, &t_left);
      int hit_right = tr_ray_hits_box(&s->bvh_nodes[left + 1], &box_ray, tmax_grown, &t_right);
      if (hit_left && hit_right) {
        int right_first = t_right < t_left;
        if (top < TR_BVH_STACK_SIZE) {
          stack_node[top] = right_first ? left : left + 1;
          stack_t[top] = right_first ? t_left : t_right;
          ++top;
        }
        next = right_first ? left + 1 : left;
      } else if (hit_left) {
        next = left;
      } else if (hit_right) {
        next = left + 1;
      }
    }
    while (next < 0 && top > 0) {
      --top;
      if (!(stack_t[top] > nearest->t * grow)) next = stack_node[top];
    }
    if (next < 0) break;
    index = next;
  }
  return any_hit ? 0 : nearest->prim >= 0;
}
