// twinray: a header-only ray tracer whose per-ray math is one text, compiled as C++
// for the CPU backend and as OpenCL C for the OpenCL backend.
//
//   #include <twinray/twinray.hpp>
//   twinray::Scene<float> scene;  ...  twinray::Camera<float> camera;
//   twinray::Image<float> image = twinray::render(scene, camera, twinray::RenderOptions{});
//
// This header is the core (scene, camera, CPU backend; GLM and threads only). Link
// twinray::opencl for the OpenCL backend and twinray::io for PNG/PFM and scene files.
#pragma once

#include <twinray/version.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/validate.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/backend/render.hpp>
