/* Camera ray through a sample position of a pixel (the original assignment's camera): the host has
 * set up the view plane (first pixel center, one-pixel steps du and dv, row 0 at the top).
 * Perspective: from the camera position toward the sample. Orthographic: along -W
 * from the sample on the view plane. */

#define TR_PROJECTION_PERSPECTIVE 0
#define TR_PROJECTION_ORTHOGRAPHIC 1

/* The frame parameters a camera ray reads, in private values: a loop over pixels that
 * holds them needs no reload per pixel (stores to the rays could alias the
 * parameters), so that it runs a pixel per SIMD lane (tr_block_camera_paths). */
typedef struct TrCamera {
  vec3 first, du, dv, origin, ortho_dir;
  int projection;
} TrCamera;

TR_FN_INLINE TrCamera tr_camera(TR_GLOBAL const TrParams* p) {
  TrCamera c;
  c.first = TR_VEC3(p->first_pixel_x, p->first_pixel_y, p->first_pixel_z);
  c.du = TR_VEC3(p->du_x, p->du_y, p->du_z);
  c.dv = TR_VEC3(p->dv_x, p->dv_y, p->dv_z);
  c.origin = TR_VEC3(p->origin_x, p->origin_y, p->origin_z);
  c.ortho_dir = TR_VEC3(p->ortho_dir_x, p->ortho_dir_y, p->ortho_dir_z);
  c.projection = p->projection;
  return c;
}

TR_FN_INLINE TrRay tr_camera_ray_of(const TrCamera* c, int px, int py, TrSample2 smp) {
  vec3 pixel = c->first + c->du * (real)px + c->dv * (real)py;
  pixel = pixel + c->du * (smp.x - TR_R(0.5)) + c->dv * (smp.y - TR_R(0.5));
  TrRay ray;
  if (c->projection == TR_PROJECTION_ORTHOGRAPHIC) {
    ray.o = pixel;
    ray.d = c->ortho_dir;
  } else {
    ray.o = c->origin;
    ray.d = tr_normalize(pixel - ray.o);
  }
  return ray;
}

TR_FN TrRay tr_camera_ray(TR_GLOBAL const TrParams* p, int px, int py, TrSample2 smp) {
  TrCamera c = tr_camera(p);
  return tr_camera_ray_of(&c, px, py, smp);
}
