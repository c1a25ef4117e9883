// The stiff and extreme scenes, in float and double, on the CPU and the
// OpenCL backend. What each case must produce is written next to it in
// robustness_cases.hpp; here every figure is held to it.
#include <doctest/doctest.h>

#include "robustness_cases.hpp"

namespace {

// Runs `run(ctx)` once with OpenCL as the backend whose image is measured and the CPU
// rendering every image a second time: the CPU image must carry the same bits (parity),
// so each figure holds for both backends. Without the OpenCL backend: the CPU alone.
// Checks what every case must satisfy (finite values, parity) and hands the figures to
// `check`.
template <class Run, class Check>
void on_backends(Run run, Check check) {
  rb::Ctx ctx;
#ifdef TWINRAY_WITH_OPENCL
  REQUIRE_MESSAGE(rb::opencl_ok(), "the OpenCL backend is built but finds no device");
  ctx.backend = rb::Backend::OpenCL;
  ctx.check_parity = true;
#endif
  rb::Figures f = run(ctx);
  CHECK(f.nonfinite == 0);
  if (ctx.check_parity) CHECK(ctx.parity == 0);
  check(f);
}

}  // namespace

TEST_CASE_TEMPLATE(
    "acne: shadow and reflected rays off a lone sphere change no pixel, scale 1e-4..1e5, offset "
    "0..1e4 sizes",
    T, float, double) {
  on_backends([](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, rb::Shape::Sphere); },
              [](const rb::Figures& f) { CHECK(f.acne == 0); });
}

TEST_CASE_TEMPLATE(
    "acne: shadow and reflected rays off a lone tilted plane change no pixel, over the sweep", T,
    float, double) {
  on_backends([](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, rb::Shape::Plane); },
              [](const rb::Figures& f) { CHECK(f.acne == 0); });
}

TEST_CASE_TEMPLATE(
    "acne: shadow and reflected rays off a closed convex mesh change no pixel, over the sweep", T,
    float, double) {
  on_backends([](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, rb::Shape::Mesh); },
              [](const rb::Figures& f) { CHECK(f.acne == 0); });
}

TEST_CASE_TEMPLATE(
    "acne: camera and light inside a sphere, shadow rays change no pixel, over the sweep", T, float,
    double) {
  on_backends([](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, rb::Shape::InsideSphere); },
              [](const rb::Figures& f) { CHECK(f.acne == 0); });
}

TEST_CASE_TEMPLATE(
    "acne through instances: a sphere, a mesh and a sphere from inside, each an asset placed "
    "unevenly scaled, mirrored and turned, change no pixel, over the sweep",
    T, float, double) {
  for (rb::Shape shape : {rb::Shape::Sphere, rb::Shape::Mesh, rb::Shape::InsideSphere}) {
    CAPTURE(rb::shape_name(shape));
    on_backends([shape](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, shape, true); },
                [](const rb::Figures& f) { CHECK(f.acne == 0); });
  }
}

TEST_CASE_TEMPLATE(
    "watertight through instances: a closed icosphere placed whole and as two halves meeting at "
    "a seam, scale 1e-4..1e5, far from the origin",
    T, float, double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f;
        for (bool halves : {false, true}) {
          f.add(rb::case_watertight_instanced<T>(c, rb::V3<T>(0, 0, 0), 2.0, halves));
          f.add(rb::case_watertight_instanced<T>(c, rb::V3<T>(T(148376), T(1234), T(-223423)), 2.0,
                                                 halves));
          f.add(rb::case_watertight_instanced<T>(c, rb::V3<T>(T(3e-4), T(-1e-4), T(2e-4)), 1e-4,
                                                 halves));
          f.add(rb::case_watertight_instanced<T>(c, rb::V3<T>(T(1e5), 0, 0), 1e5, halves));
        }
        return f;
      },
      [](const rb::Figures& f) {
        CHECK(f.samples > 40000);
        CHECK(f.leaks == 0);
      });
}

TEST_CASE_TEMPLATE(
    "watertight: tiled grids, rays through shared vertices, edges and diagonals, far from the "
    "origin",
    T, float, double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f;
        for (double s : {1e-4, 1.0, 1e5})
          for (double off : {0.0, 1e4})
            for (bool tilted : {false, true}) f.add(rb::case_watertight_grid<T>(c, s, off, tilted));
        return f;
      },
      [](const rb::Figures& f) {
        CHECK(f.samples > 10000);
        CHECK(f.leaks == 0);
      });
}

TEST_CASE_TEMPLATE(
    "watertight: closed icosphere seen from inside, at the origin and at (148376, 1234, -223423)",
    T, float, double) {
  on_backends(
      [](rb::Ctx& c) {
        const bool single = true;  // single rays: the device code on the host
        rb::Figures f = rb::case_watertight_closed<T>(c, rb::V3<T>(0, 0, 0), T(2), single);
        f.add(rb::case_watertight_closed<T>(c, rb::V3<T>(T(148376), T(1234), T(-223423)), T(2),
                                            single));
        f.add(rb::case_watertight_closed<T>(c, rb::V3<T>(T(3e-4), T(-1e-4), T(2e-4)), T(1e-4),
                                            single));
        return f;
      },
      [](const rb::Figures& f) { CHECK(f.leaks == 0); });
}

TEST_CASE_TEMPLATE("tiny far sphere: the hit mask is the analytic disk at distances 1e2..1e5", T,
                   float, double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f;
        for (double d : {1e2, 2e2, 2e3, 4.1e3, 1e5}) f.add(rb::case_tiny_far_sphere<T>(c, d));
        return f;
      },
      [](const rb::Figures& f) { CHECK(f.wrong == 0); });
}

TEST_CASE_TEMPLATE(
    "huge sphere: a 1e5-radius ground sphere matches its reference and covers like a plane", T,
    float, double) {
  on_backends([](rb::Ctx& c) { return rb::case_huge_sphere<T>(c); },
              [](const rb::Figures& f) {
                CHECK(f.wrong == 0);
                CHECK(f.terr_max <= 64);
              });
}

TEST_CASE_TEMPLATE("grazing: camera 1e-3 above a plane, parallel rays, camera in the plane", T,
                   float, double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f = rb::case_grazing<T>(c, 1e-3, 0.0);
        f.add(rb::case_grazing<T>(c, 1e-3, 1e3));
        f.add(rb::case_grazing<T>(c, 1.0, 0.0));
        return f;
      },
      [](const rb::Figures& f) {
        CHECK(f.wrong == 0);
        CHECK(f.acne == 0);
        CHECK(f.terr_max <= 8);
      });
}

TEST_CASE_TEMPLATE(
    "degenerate and needle triangles: never hit when zero-area, watertight when needles", T, float,
    double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f = rb::case_degenerate<T>(c, 1.0);
        f.add(rb::case_degenerate<T>(c, 1e-3));
        f.add(rb::case_degenerate<T>(c, 1e4));
        return f;
      },
      [](const rb::Figures& f) {
        CHECK(f.wrong == 0);
        CHECK(f.leaks == 0);
      });
}

TEST_CASE_TEMPLATE("shininess 0..1e4 and light intensity 0 and 1e30 stay finite and consistent", T,
                   float, double) {
  on_backends([](rb::Ctx& c) { return rb::case_shininess_intensity<T>(c); },
              [](const rb::Figures& f) { CHECK(f.wrong == 0); });
}

TEST_CASE_TEMPLATE("two facing mirrors at depth 64 match the closed-form geometric sum", T, float,
                   double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f = rb::case_mirrors<T>(c, T(0.5));
        f.add(rb::case_mirrors<T>(c, T(1)));
        return f;
      },
      [](const rb::Figures& f) { CHECK(f.wrong == 0); });
}

TEST_CASE_TEMPLATE(
    "glass: slabs and thin sheets at 0..80 degrees show their closed-form reflectance plus "
    "transmittance, scale 1e-4..1e5, offset 0..1e4 sizes",
    T, float, double) {
  on_backends(
      [](rb::Ctx& c) {
        rb::Figures f;
        for (double s : rb::sweep_scales())
          for (double off : rb::sweep_offsets())
            for (double degrees : {0.0, 40.0, 80.0})
              for (bool thin : {false, true})
                f.add(rb::case_glass_slab<T>(c, s, off, degrees, thin));
        return f;
      },
      [](const rb::Figures& f) {
        MESSAGE("glass slabs: largest relative error ", f.rel_err_max);
        CHECK(f.wrong == 0);
      });
}

TEST_CASE_TEMPLATE("hit-distance error sweep in ulps against long double, scale 1e-4..1e5", T,
                   float, double) {
  for (rb::Prim p : {rb::Prim::Sphere, rb::Prim::Triangle, rb::Prim::Plane}) {
    CAPTURE(rb::prim_name(p));
    rb::Figures f = rb::case_t_sweep<T>(p);
    MESSAGE(rb::prim_name(p), ": max ", f.terr_max, " ulp, median ", f.terr_median, " ulp");
    CHECK(f.leaks == 0);
    CHECK(f.nonfinite == 0);
    CHECK(f.terr_median <= 2);
    CHECK(f.terr_max <= 64);
  }
}
