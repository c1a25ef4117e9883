/* All device functions, in dependency order (OpenCL C needs a function declared
 * before its use). The host includes this file inside
 * `template <unsigned TR_FEATURES> struct Kernel`; kernels/render.cl includes it at
 * file scope. Nothing here but functions and macros: every struct is in types.h. */
#include "math.h"
#include "sampling.h"
#include "camera_ray.h"
#include "hit.h"
#include "intersect_sphere.h"
#include "intersect_triangle.h"
#include "intersect_plane.h"
#include "ray_offset.h"
#include "instance.h"
#include "bvh_traverse.h"
#include "bvh_packet.h"
#include "scene_hit.h"
#include "ray_query.h"
#include "texture.h"
#include "environment.h"
#include "area_light.h"
#include "dielectric.h"
#include "shading.h"
#include "trace.h"
#include "adaptive.h"
