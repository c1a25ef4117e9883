/* Camera ray through a sample position of a pixel (the original assignment's camera): the host has
 * set up the view plane (first pixel center, one-pixel steps du and dv, row 0 at the top).
 * Perspective: from the camera position toward the sample. Orthographic: along -W
 * from the sample on the view plane. */

#define TR_PROJECTION_PERSPECTIVE 0
#define TR_PROJECTION_ORTHOGRAPHIC 1

TR_FN TrRay tr_camera_ray(TR_GLOBAL const TrParams* p, int px, int py, TrSample2 smp) {
  vec3 first = TR_VEC3(p->first_pixel_x, p->first_pixel_y, p->first_pixel_z);
  vec3 du = TR_VEC3(p->du_x, p->du_y, p->du_z);
  vec3 dv = TR_VEC3(p->dv_x, p->dv_y, p->dv_z);
  vec3 pixel = first + du * (real)px + dv * (real)py;
  pixel = pixel + du * (smp.x - TR_R(0.5)) + dv * (smp.y - TR_R(0.5));
  TrRay ray;
  if (p->projection == TR_PROJECTION_ORTHOGRAPHIC) {
    ray.o = pixel;
    ray.d = TR_VEC3(p->ortho_dir_x, p->ortho_dir_y, p->ortho_dir_z);
  } else {
    ray.o = TR_VEC3(p->origin_x, p->origin_y, p->origin_z);
    ray.d = tr_normalize(pixel - ray.o);
  }
  return ray;
}
