// Camera basis and first pixel center for both projections (the original assignment's formulas).
#include <doctest/doctest.h>

#include <cmath>

#include <twinray/device/code.hpp>
#include <twinray/scene/camera.hpp>

using twinray::Camera;
using twinray::Projection;

namespace {
template <class T>
void check_vec(const glm::vec<3, T>& got, const glm::vec<3, T>& want, double eps = 1e-6) {
  for (int i = 0; i < 3; ++i) CHECK(got[i] == doctest::Approx(want[i]).epsilon(eps));
}
}  // namespace

TEST_CASE_TEMPLATE("seed camera: basis, focal length and first pixel center", T, float, double) {
  using vec3 = glm::vec<3, T>;
  Camera<T> cam;  // defaults: the seed's (4,-1,5) looking at (0,0,-1), up (0,-1,0), 400x400
  auto f = cam.frame();
  // W = normalize(position - look_at) = (4,-1,6)/sqrt(53)
  const double s53 = std::sqrt(53.0);
  check_vec<T>(f.w, vec3(T(4 / s53), T(-1 / s53), T(6 / s53)));
  CHECK(f.focal_length == doctest::Approx(s53));
  // U = normalize(up x W), V = W x U: orthonormal, V points to -y (the scene's up).
  CHECK(glm::dot(f.u, f.w) == doctest::Approx(0).epsilon(1e-6));
  CHECK(glm::dot(f.v, f.w) == doctest::Approx(0).epsilon(1e-6));
  CHECK(glm::length(f.u) == doctest::Approx(1));
  CHECK(glm::length(f.v) == doctest::Approx(1));
  CHECK(f.v.y < 0);
  // View plane 6 x 6 centered on look_at; pixel steps 6/400 along U and -V.
  check_vec<T>(f.du, f.u * T(6.0 / 400));
  check_vec<T>(f.dv, -f.v * T(6.0 / 400));
  vec3 upper_left = cam.look_at - f.u * T(3) + f.v * T(3);
  check_vec<T>(f.first_pixel, upper_left + (f.du + f.dv) * T(0.5), 1e-5);
}

TEST_CASE_TEMPLATE("perspective rays start at the camera, the center pixel looks at look_at", T,
                   float, double) {
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  Camera<T> cam;
  cam.width = 3, cam.height = 3;  // odd: pixel (1,1) is the view plane's center
  auto f = cam.frame();
  typename twinray::device::Code<T>::Params p{};
  p.first_pixel_x = f.first_pixel.x, p.first_pixel_y = f.first_pixel.y,
  p.first_pixel_z = f.first_pixel.z;
  p.du_x = f.du.x, p.du_y = f.du.y, p.du_z = f.du.z;
  p.dv_x = f.dv.x, p.dv_y = f.dv.y, p.dv_z = f.dv.z;
  p.origin_x = f.origin.x, p.origin_y = f.origin.y, p.origin_z = f.origin.z;
  p.ortho_dir_x = f.ortho_dir.x, p.ortho_dir_y = f.ortho_dir.y, p.ortho_dir_z = f.ortho_dir.z;
  typename twinray::device::Code<T>::Sample2 center{T(0.5), T(0.5)};
  auto ray = K::tr_camera_ray(&p, 1, 1, center);
  check_vec<T>(ray.o, cam.position);
  check_vec<T>(ray.d, glm::normalize(cam.look_at - cam.position), 1e-5);
  // Row 0 is the top of the image: the scene's up is -y, so row 0 looks higher (lower y).
  auto top = K::tr_camera_ray(&p, 1, 0, center);
  auto bottom = K::tr_camera_ray(&p, 1, 2, center);
  CHECK(top.d.y < bottom.d.y);

  p.projection = TR_PROJECTION_ORTHOGRAPHIC;
  Camera<T> ortho = cam;
  ortho.projection = Projection::Orthographic;
  auto fo = ortho.frame();
  CHECK(fo.focal_length == T(0));
  p.first_pixel_x = fo.first_pixel.x, p.first_pixel_y = fo.first_pixel.y,
  p.first_pixel_z = fo.first_pixel.z;
  auto oray = K::tr_camera_ray(&p, 1, 1, center);
  check_vec<T>(oray.o, cam.position, 1e-5);  // focal 0: the view plane passes the camera
  check_vec<T>(oray.d, -fo.w);
  auto corner = K::tr_camera_ray(&p, 0, 0, center);
  check_vec<T>(corner.d, -fo.w);  // every orthographic ray is parallel
  check_vec<T>(corner.o, fo.first_pixel);
}

TEST_CASE("focal length and aspect ratio") {
  Camera<double> cam;
  cam.focal_length = 2.0;
  cam.width = 800, cam.height = 400;
  auto f = cam.frame();
  CHECK(f.focal_length == 2.0);
  CHECK(glm::length(f.du) * 800 == doctest::Approx(12.0));  // width = height x aspect
  CHECK(glm::length(f.dv) * 400 == doctest::Approx(6.0));
}
