// twinray: a header-only ray tracer whose per-ray math is one text, compiled as C++
// for the CPU backend and as OpenCL C for the OpenCL backend.
//
//   #include <twinray/twinray.hpp>
//   twinray::Scene<float> scene;  ...  twinray::Camera<float> camera;
//   twinray::Image<float> image = twinray::render(scene, camera, twinray::RenderOptions{});
//
// A frame loop keeps one backend and packs the scene once (backend/backend.hpp):
//   auto backend = twinray::make_backend<float>(options);
//   backend->set_scene(twinray::share(twinray::pack_scene(scene, backend->pack_options())));
//   twinray::Image<float> frame = backend->render({camera, scene.lights, options});
//
// This header is the core (scene, camera, CPU backend; GLM and threads only). Link
// twinray::opencl for the OpenCL backend and twinray::io for PNG/PFM and scene files.
#pragma once

#include <twinray/version.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/scene/validate.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/scene/transform.hpp>
#include <twinray/pack/pack.hpp>
#include <twinray/backend/backend.hpp>
#include <twinray/backend/render.hpp>
