/* The whole path of one camera ray: closest hit, shading, then the glaze loop.
 * Glazed surfaces add glaze x (what the mirrored ray sees), the assignment's
 * reflected = d - 2 (d.n) n. OpenCL C has no recursion, so the mirror chain is a
 * loop carrying the product of the glaze factors; max_depth counts ray segments
 * (1 = camera rays only). Values stay linear HDR; clamping happens at output.
 *
 * Glass (TR_F_DIELECTRIC, dielectric.h) splits a path in two: the refracted ray, with
 * weight transmission (1 - F), goes on at once, and the reflected one, with weight
 * glaze + transmission F (F the Fresnel reflectance; 1 under total internal reflection),
 * waits on the path's stack of pending rays (TrRayStack), each keeping the segments left
 * to it. The tree is walked depth first, so both backends add its rays' colors in one
 * order. A ray whose weight falls below TR_MIN_WEIGHT in every channel is not traced. */
#define TR_MIN_WEIGHT TR_R(0.0009765625) /* 2^-10 */

/* A camera ray's path before its first segment. */
TR_FN TrPath tr_path_start(const TrSceneRef* s, TrRay ray) {
  TrPath path;
  path.ray = ray;
  path.from = ray.o;
  path.color = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  path.weight = TR_VEC3(TR_R(1.0), TR_R(1.0), TR_R(1.0));
  path.segments_left =
      tr_use(s, TR_F_GLAZE) || tr_use(s, TR_F_DIELECTRIC) ? s->params->max_depth : 1;
  return path;
}

/* Ends the path's current ray: the path takes its last pending ray, if it has one (only
 * glass pushes any: the stack is not read in scenes without it). */
TR_FN_INLINE void tr_path_next(const TrSceneRef* s, TrPath* path, TrRayStack* stack) {
  path->segments_left = 0;
  if (!tr_use(s, TR_F_DIELECTRIC) || stack->n == 0) return;
  --stack->n;
  path->ray = stack->ray[stack->n].ray;
  path->from = stack->ray[stack->n].from;
  path->weight = stack->ray[stack->n].weight;
  path->segments_left = stack->ray[stack->n].segments_left;
}

/* The path's ray continued from the hit along unit direction w. */
TR_FN_INLINE TrRay tr_ray_from_hit(const TrHit* hit, vec3 w) {
  TrRay ray;
  ray.o = tr_offset_ray_origin(hit->p, hit->perr, hit->n, w);
  ray.d = w;
  return ray;
}

/* At a surface of a transmissive material: the refracted ray goes on, the reflected one
 * waits on the stack (both where their weights are large enough and segments are
 * left). The normal is the shading normal, turned to face the incoming ray, unless it
 * then faces away from the geometric one's facing side (the geometric one serves). */
TR_FN void tr_path_split(const TrSceneRef* s, TrPath* path, TrRayStack* stack, const TrHit* hit) {
  TR_GLOBAL const TrMaterial* m = &s->materials[hit->material];
  vec3 d = path->ray.d;
  if (path->segments_left <= 0) {
    tr_path_next(s, path, stack);
    return;
  }
  real eta = tr_dot(d, hit->n) < TR_R(0.0) ? m->ior : TR_R(1.0) / m->ior;
  vec3 n = tr_dot(d, hit->ns) < TR_R(0.0) ? hit->ns : -hit->ns;
  if (!(tr_dot(n, hit->n) * tr_dot(d, hit->n) < TR_R(0.0)) || tr_dot(d, n) >= TR_R(0.0))
    n = tr_dot(d, hit->n) < TR_R(0.0) ? hit->n : -hit->n;
  real cos_i = -tr_dot(d, n);
  real cos_t = TR_R(0.0);
  real fresnel = tr_fresnel_dielectric(cos_i, eta, &cos_t);
  real glaze = tr_use(s, TR_F_GLAZE) ? m->glaze : TR_R(0.0);
  vec3 reflected_weight = path->weight * (glaze + m->transmission * fresnel);
  vec3 refracted_weight = path->weight * (m->transmission * (TR_R(1.0) - fresnel));
  int reflect = tr_max_component(reflected_weight) >= TR_MIN_WEIGHT;
  int refract = fresnel < TR_R(1.0) && tr_max_component(refracted_weight) >= TR_MIN_WEIGHT;
  vec3 mirrored = tr_normalize(d - n * (TR_R(2.0) * tr_dot(d, n)));
  if (refract) {
    if (reflect && stack->n < TR_RAY_STACK) {
      stack->ray[stack->n].ray = tr_ray_from_hit(hit, mirrored);
      stack->ray[stack->n].from = hit->p;
      stack->ray[stack->n].weight = reflected_weight;
      stack->ray[stack->n].segments_left = path->segments_left;
      ++stack->n;
    }
    path->ray = tr_ray_from_hit(hit, tr_refract(d, n, cos_i, eta, cos_t));
    path->from = hit->p;
    path->weight = refracted_weight;
  } else if (reflect) {
    path->ray = tr_ray_from_hit(hit, mirrored);
    path->from = hit->p;
    path->weight = reflected_weight;
  } else {
    tr_path_next(s, path, stack);
  }
}

/* One segment of the path, whose ray's closest hit is (found, hit) and shades to
 * `shaded` there: adds what it sees and, on a glazed surface, turns the path into the
 * mirrored ray; on glass, splits it (tr_path_split); else the path takes its next
 * pending ray, if any. */
TR_FN_INLINE void tr_path_step(const TrSceneRef* s, TrPath* path, TrRayStack* stack, int found,
                               const TrHit* hit, vec3 shaded) {
  --path->segments_left;
  if (!found) {
    path->color = path->color + tr_miss_rgb(s, path->ray.d) * path->weight;
    tr_path_next(s, path, stack);
    return;
  }
  vec3 d = path->ray.d;
  if (tr_use(s, TR_F_DIELECTRIC))
    path->weight = path->weight * tr_absorption(s, hit, d, tr_length(hit->p - path->from));
  path->color = path->color + shaded * path->weight;
  if (tr_use(s, TR_F_DIELECTRIC) && s->materials[hit->material].transmission > TR_R(0.0)) {
    tr_path_split(s, path, stack, hit);
    return;
  }
  real glaze = TR_HAS(TR_F_GLAZE) ? s->materials[hit->material].glaze : TR_R(0.0);
  if (!(glaze > TR_R(0.0)) || !tr_use(s, TR_F_GLAZE)) {
    tr_path_next(s, path, stack);
    return;
  }
  vec3 n = hit->ns; /* the shading normal mirrors; the geometric one offsets */
  vec3 mirrored = tr_normalize(d - n * (TR_R(2.0) * tr_dot(d, n)));
  path->ray.o = tr_offset_ray_origin(hit->p, hit->perr, hit->n, mirrored);
  path->ray.d = mirrored;
  path->from = hit->p;
  path->weight = path->weight * glaze;
}

/* The color a camera ray's path brings back; seed: the word its area lights' samples come
 * from (tr_sample_seed). */
TR_FN vec3 tr_trace(const TrSceneRef* s, TrRay ray, unsigned int seed) {
  TrRayStack stack;
  stack.n = 0;
  TrPath path = tr_path_start(s, ray);
  while (path.segments_left > 0) {
    TrHit hit = tr_no_hit();
    int found = tr_closest_hit(s, &path.ray, TR_R(INFINITY), &hit);
    vec3 shaded =
        found ? tr_shade(s, &hit, path.ray.d, seed) : TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
    tr_path_step(s, &path, &stack, found, &hit, shaded);
  }
  return path.color;
}

/* The seed word of sample i's path in pixel (px, py): tr_path_seed where area lights
 * are compiled in (else never read). */
TR_FN_INLINE unsigned int tr_sample_seed(const TrSceneRef* s, int px, int py, int i) {
  return tr_use(s, TR_F_AREA_LIGHTS) ? tr_path_seed(px, py, i, s->params->seed) : 0u;
}

/* Mean of the pixel's samples; the summation order is fixed, so both sides agree. */
TR_FN vec3 tr_render_pixel(const TrSceneRef* s, int px, int py) {
  TR_GLOBAL const TrParams* p = s->params;
  vec3 sum = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < p->spp; ++i) {
    TrSample2 smp = tr_sample_position_seeded(p->sampler, p->seed, i, p->spp, px, py);
    sum = sum + tr_trace(s, tr_camera_ray(p, px, py, smp), tr_sample_seed(s, px, py, i));
  }
  return sum * (TR_R(1.0) / (real)p->spp);
}

/* The block at position `index` in the order both backends hand a rectangle's
 * blocks_x x blocks_y blocks to their threads: tiles of TR_TILE_BLOCKS x TR_TILE_BLOCKS
 * blocks, row by row of tiles, and each tile's blocks row by row; the tiles of the last
 * row and column are cut to the rectangle. A thread that takes consecutive positions
 * renders neighbouring blocks one after the other, whose rays meet the same nodes and
 * primitives while they are still in its core's caches: CPU frames took 0.98-0.99 of
 * the time they took with blocks handed out row by row, PoCL's the same within the
 * noise (docs/performance.md). A bijection of [0, blocks_x blocks_y) onto the blocks;
 * (*bx, *by) in blocks. */
TR_FN_INLINE void tr_tiled_block(int index, int blocks_x, int blocks_y, int* bx, int* by) {
  int tile_y = index / (TR_TILE_BLOCKS * blocks_x) * TR_TILE_BLOCKS; /* its tile row's top */
  int tile_h = blocks_y - tile_y < TR_TILE_BLOCKS ? blocks_y - tile_y : TR_TILE_BLOCKS;
  int in_row = index - tile_y * blocks_x; /* the tile row holds tile_h blocks_x blocks */
  int tile_x = in_row / (TR_TILE_BLOCKS * tile_h) * TR_TILE_BLOCKS;
  int tile_w = blocks_x - tile_x < TR_TILE_BLOCKS ? blocks_x - tile_x : TR_TILE_BLOCKS;
  int in_tile = in_row - tile_x * tile_h;
  *bx = tile_x + in_tile % tile_w;
  *by = tile_y + in_tile / tile_w;
}

/* Sample i's camera rays of the block of w x h pixels from (x0, y0), as tr_render_pixel
 * makes them, into b->path[0 .. w h) (rows of w): row by row, with no integer division
 * per pixel, the grid's position (the same in every pixel) found once, and the rays of
 * a row computed a pixel per SIMD lane. The packet's arrays, which hold nothing between
 * queries (tr_packet_begin fills them), serve as the row's scratch: the sample
 * positions in ix and iy, the rays in ox .. dz. Made pixel by pixel, with four integer
 * divisions each, the camera rays took 7% of a mesh_1e6 frame (docs/performance.md). */
TR_FN_INLINE void tr_block_camera_paths(const TrSceneRef* s, TrBlockScratch* b, int x0, int y0,
                                        int w, int h, int i) {
  TR_GLOBAL const TrParams* p = s->params;
  TrRayPacket* pk = &b->packet;
  TrCamera camera = tr_camera(p);
  int per_pixel = tr_sampler_per_pixel(p->sampler);
  TrSample2 grid = tr_sample_grid(i, p->spp);
  for (int y = 0; y < h; ++y) {
    real* smp_x = pk->ix;
    real* smp_y = pk->iy;
    for (int x = 0; x < w; ++x) {
      TrSample2 smp =
          per_pixel ? tr_sample_position_seeded(p->sampler, p->seed, i, p->spp, x0 + x, y0 + y)
                    : grid;
      smp_x[x] = smp.x;
      smp_y[x] = smp.y;
    }
    TR_SIMD_LOOP
    for (int x = 0; x < w; ++x) {
      TrSample2 smp;
      smp.x = smp_x[x];
      smp.y = smp_y[x];
      tr_packet_set_ray(pk, x, tr_camera_ray_of(&camera, x0 + x, y0 + y, smp));
    }
    for (int x = 0; x < w; ++x) b->path[y * w + x] = tr_path_start(s, tr_packet_ray(pk, x));
    if (tr_use(s, TR_F_AREA_LIGHTS))
      for (int x = 0; x < w; ++x)
        b->path_seed[y * w + x] = tr_path_seed(x0 + x, y0 + y, i, p->seed);
  }
}

/* tr_render_pixel for a block of w x h pixels from (x0, y0), w h <= TR_PACKET_MAX,
 * into colors[w h] (rows of w): the same values, computed a segment at a time for all
 * the block's paths, so that each segment's rays, and its shadow rays toward each
 * light, are found in one packet query (scene_hit.h). Shading goes light by light over
 * the segment's hits, adding each hit's terms in tr_shade's order, so each path takes
 * the same steps as in tr_trace; only the order across pixels differs. The CPU
 * backend's path for shaded frames. */
TR_FN void tr_render_block(const TrSceneRef* s, TrBlockScratch* b, TrRayStack* stacks, int x0,
                           int y0, int w, int h, vec3* colors) {
  TR_GLOBAL const TrParams* p = s->params;
  TrRayPacket* pk = &b->packet;
  int n = w * h;
  for (int j = 0; j < n; ++j) colors[j] = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  for (int i = 0; i < p->spp; ++i) {
    tr_block_camera_paths(s, b, x0, y0, w, h, i);
    if (tr_use(s, TR_F_DIELECTRIC))
      for (int j = 0; j < n; ++j) stacks[j].n = 0;
    for (;;) {
      int m = 0;
      for (int j = 0; j < n; ++j) {
        if (b->path[j].segments_left <= 0) continue;
        pk->ray[m] = b->path[j].ray;
        b->slot[m++] = j;
      }
      if (m == 0) break;
      pk->n = m;
      tr_closest_hit_packet(s, pk, b->hit, b->found);
      /* The rays that hit, in order: f of them, ray b->found_ray[q] the q-th, and what
       * the light loop reads of each hit in one array per component. */
      int f = 0;
      for (int r = 0; r < m; ++r) {
        b->shaded[r] = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
        if (!b->found[r]) continue;
        const TrHit* hit = &b->hit[r];
        vec3 d = b->path[b->slot[r]].ray.d;
        TrSurface sf = tr_surface(s, hit, d);
        b->surface[r] = sf;
        b->found_ray[f] = r;
        tr_set_lane3(&b->hit_p, f, hit->p);
        tr_set_lane3(&b->hit_shadow_p, f, hit->shadow_p);
        tr_set_lane3(&b->hit_shadow_perr, f, hit->shadow_perr);
        tr_set_lane3(&b->hit_n, f, hit->n);
        tr_set_lane3(&b->hit_facing_n, f++, sf.n);
      }
      for (int light = 0; light < p->n_lights && f > 0; ++light) {
        for (int k = 0; k < tr_light_samples(s, light); ++k) {
          /* Where each hit sees the light (sample k of an area light: area_light.h). */
          if (tr_use(s, TR_F_AREA_LIGHTS)) {
            for (int q = 0; q < f; ++q)
              tr_set_lane3(
                  &b->light_pos, q,
                  tr_light_sample_position(s, light, k, b->path_seed[b->slot[b->found_ray[q]]],
                                           tr_lane3(&b->hit_p, q)));
          } else {
            TR_GLOBAL const TrLight* lp = &s->lights[light];
            vec3 light_pos = TR_VEC3(lp->px, lp->py, lp->pz);
            for (int q = 0; q < f; ++q) tr_set_lane3(&b->light_pos, q, light_pos);
          }
          /* Every hit's view of the light and shadow ray, a hit per SIMD lane (no slower
           * than a hit at a time, and up to 8% faster: docs/performance.md); then
           * the shadow rays asked for, moved to the front of the packet's arrays (never
           * backwards: k <= q). */
          TR_INDEPENDENT_LOOP
          for (int q = 0; q < f; ++q) {
            TrLightView lv = tr_light_view(s, tr_lane3(&b->hit_p, q), tr_lane3(&b->hit_facing_n, q),
                                           light, tr_lane3(&b->light_pos, q));
            TrRay shadow;
            real tmax;
            b->shadow_traced[q] = tr_light_needs_shadow_ray(s, lv, tr_lane3(&b->hit_shadow_p, q),
                                                            tr_lane3(&b->hit_shadow_perr, q),
                                                            tr_lane3(&b->hit_n, q), &shadow, &tmax);
            tr_set_lane3(&b->light_irradiance, q, lv.irradiance);
            tr_set_lane3(&b->light_l, q, lv.l);
            b->light_n_dot_l[q] = lv.n_dot_l;
            b->light_lit[q] = lv.lit;
            tr_packet_set_ray(pk, q, shadow);
            pk->t[q] = tmax;
            b->blocked[q] = 0;
          }
          int traced = 0;
          for (int q = 0; q < f; ++q) {
            if (!b->shadow_traced[q]) continue;
            pk->ray[traced] = tr_packet_ray(pk, q);
            pk->t[traced] = pk->t[q];
            b->lane[traced++] = q;
          }
          if (traced > 0) {
            pk->n = traced;
            tr_any_hit_packet(s, pk, b->lane_blocked);
            for (int j = 0; j < traced; ++j) b->blocked[b->lane[j]] = b->lane_blocked[j];
          }
          /* What passes glass on the blocked shadow rays, as tr_shade finds it. */
          if (tr_use(s, TR_F_DIELECTRIC)) {
            for (int q = 0; q < f; ++q) {
              b->through[q] = TR_R(1.0);
              if (!b->blocked[q]) continue;
              TrRay shadow;
              real tmax;
              tr_shadow_ray(tr_lane3(&b->hit_shadow_p, q), tr_lane3(&b->hit_shadow_perr, q),
                            tr_lane3(&b->hit_n, q), tr_lane3(&b->light_pos, q), &shadow, &tmax);
              b->through[q] = tr_shadow_through(s, shadow, tmax, &b->blocked[q]);
            }
          }
          /* tr_add_light, hit by hit, with the specular powers of all hits between its
           * two halves. */
          for (int r = 0; r < m; ++r) {
            b->specular[r] = 0;
            b->n_dot_h[r] = TR_R(0.0);
          }
          TrLightView lv;
          for (int q = 0; q < f; ++q) {
            int r = b->found_ray[q];
            lv.irradiance = tr_lane3(&b->light_irradiance, q);
            lv.l = tr_lane3(&b->light_l, q);
            lv.n_dot_l = b->light_n_dot_l[q];
            lv.lit = b->light_lit[q];
            real through = TR_HAS(TR_F_DIELECTRIC) ? b->through[q] : TR_R(1.0);
            b->shaded[r] = tr_add_light_before_power(
                s, &b->hit[r], b->surface[r], b->path[b->slot[r]].ray.d, lv, b->blocked[q], through,
                b->shaded[r], &b->n_dot_h[r], &b->specular[r]);
          }
          tr_specular_powers(s, b->hit, b->specular, b->n_dot_h, m, b->power);
          for (int q = 0; q < f; ++q) {
            int r = b->found_ray[q];
            if (!b->specular[r]) continue;
            lv.irradiance = tr_lane3(&b->light_irradiance, q);
            real through = TR_HAS(TR_F_DIELECTRIC) ? b->through[q] : TR_R(1.0);
            b->shaded[r] = tr_add_specular(s, &b->hit[r], lv, through, b->power[r], b->shaded[r]);
          }
        }
      }
      for (int r = 0; r < m; ++r)
        tr_path_step(s, &b->path[b->slot[r]], &stacks[TR_HAS(TR_F_DIELECTRIC) ? b->slot[r] : 0],
                     b->found[r], &b->hit[r], b->shaded[r]);
    }
    for (int j = 0; j < n; ++j) colors[j] = colors[j] + b->path[j].color;
  }
  for (int j = 0; j < n; ++j) colors[j] = colors[j] * (TR_R(1.0) / (real)p->spp);
}

/* Arbitrary output variables of the primary ray through the pixel center. */
#define TR_AOV_DEPTH 0          /* hit distance t; +inf where nothing is hit */
#define TR_AOV_NORMAL 1         /* unit geometric normal as stored (not turned); 0 where no hit */
#define TR_AOV_OBJECT 2         /* object index in the scene; -1 where no hit */
#define TR_AOV_SHADING_NORMAL 3 /* unit shading normal, not turned; 0 where no hit */
#define TR_AOV_UV 4             /* texture coordinates (u, v, 0); 0 where none */

TR_FN vec3 tr_render_aov(const TrSceneRef* s, int px, int py, int aov) {
  TrSample2 center;
  center.x = TR_R(0.5);
  center.y = TR_R(0.5);
  TrHit hit = tr_no_hit();
  TrRay camera = tr_camera_ray(s->params, px, py, center);
  int found = tr_closest_hit(s, &camera, TR_R(INFINITY), &hit);
  vec3 zero = TR_VEC3(TR_R(0.0), TR_R(0.0), TR_R(0.0));
  if (aov == TR_AOV_NORMAL) return found ? hit.n : zero;
  if (aov == TR_AOV_SHADING_NORMAL) return found ? hit.ns : zero;
  if (aov == TR_AOV_UV) return found ? TR_VEC3(hit.u, hit.v, TR_R(0.0)) : zero;
  real v = aov == TR_AOV_DEPTH ? (found ? hit.t : TR_R(INFINITY))
                               : (found ? (real)hit.object : TR_R(-1.0));
  return TR_VEC3(v, v, v);
}

/* Framebuffer: linear RGB, 3 reals per pixel, row 0 at the top. */
TR_FN void tr_store_rgb(TR_GLOBAL real* out, int width, int px, int py, vec3 c) {
  int i = (py * width + px) * 3;
  out[i] = c.x;
  out[i + 1] = c.y;
  out[i + 2] = c.z;
}

/* How many blocks of TR_BLOCK_SIDE pixels cover a side of `pixels` pixels, the last
 * one cut to it. */
TR_FN_INLINE int tr_blocks_across(int pixels) {
  return (pixels + TR_BLOCK_SIDE - 1) / TR_BLOCK_SIDE;
}

/* How many blocks of TR_BLOCK_SIDE x TR_BLOCK_SIDE pixels cover the frame's rectangle:
 * the length of the block kernel's range and of the CPU backend's loop over blocks. */
TR_FN_INLINE int tr_block_count(TR_GLOBAL const TrParams* p) {
  return tr_blocks_across(p->rect_w) * tr_blocks_across(p->rect_h);
}

/* Renders the block at position `index` (tr_tiled_block's order) of the frame's
 * rectangle into out, rect_w x rect_h pixels (tr_store_rgb); nothing where index is
 * past the last block. One work-item of the block kernel, one step of the CPU
 * backend's loop over blocks. stacks: the pending rays of each of the block's paths,
 * TR_BLOCK_SIDE^2 of them where glass is compiled in (else one, never read): the
 * caller's, so that the CPU's threads keep theirs from block to block instead of
 * making a frame of 29 KB (float) for every block. */
TR_FN void tr_render_block_at(const TrSceneRef* s, TrBlockScratch* b, TrRayStack* stacks, int index,
                              TR_GLOBAL real* out) {
  TR_GLOBAL const TrParams* p = s->params;
  if (index >= tr_block_count(p)) return;
  int bx = 0, by = 0;
  tr_tiled_block(index, tr_blocks_across(p->rect_w), tr_blocks_across(p->rect_h), &bx, &by);
  int x = bx * TR_BLOCK_SIDE, y = by * TR_BLOCK_SIDE;
  int w = p->rect_w - x < TR_BLOCK_SIDE ? p->rect_w - x : TR_BLOCK_SIDE;
  int h = p->rect_h - y < TR_BLOCK_SIDE ? p->rect_h - y : TR_BLOCK_SIDE;
  vec3 colors[TR_BLOCK_SIDE * TR_BLOCK_SIDE];
  tr_render_block(s, b, stacks, p->rect_x + x, p->rect_y + y, w, h, colors);
  for (int k = 0; k < w * h; ++k) tr_store_rgb(out, p->rect_w, x + k % w, y + k / w, colors[k]);
}
