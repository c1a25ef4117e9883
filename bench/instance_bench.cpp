// Instances: what a placement costs in memory and in build time, against Embree's
// instance geometry where Embree 3 is found. Prints figures; it is not a test.
//
//   instance_bench [--instances K] [--triangles N] [--moving M] [--frames F] [--runs R]
//
// On the forest_<K>x<N> benchmark scene (apps/twinray/bench/bench_scenes.hpp: N
// triangles as one asset, K instances of it):
//  - packed bytes of one instance and of all K (PackedScene::bytes), and what each
//    instance past the first adds;
//  - the process's peak resident memory after packing the forest;
//  - the top-level build: update_instances (pack/pack.hpp) over the K instances, the
//    median of R, against Embree's rtcCommitScene of a scene of the same K instance
//    geometries over one committed asset scene (geometry creation included, as in
//    embree_bench), measured alternately in this one process;
//  - moving instances: M instances moved every frame for F frames, each frame's
//    update_instances (the assets stay packed), median and largest, and the bytes a
//    device that copies the scene gets per frame (the top level and the instances).
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include "bench_runner.hpp"
#include "bench_scenes.hpp"
#include "bench_stats.hpp"

#ifdef TWINRAY_BENCH_WITH_EMBREE
#include "embree_world.hpp"
#endif

namespace {

#ifdef TWINRAY_BENCH_WITH_EMBREE
// Embree's top level: a new scene of one instance geometry per placement of `asset`,
// committed; the time of the whole, in ms.
double embree_top_level_ms(RTCDevice device, RTCScene asset, const twinray::Scene<float>& scene) {
  auto t0 = std::chrono::steady_clock::now();
  RTCScene top = rtcNewScene(device);
  for (const auto& o : scene.objects) {
    auto* in = std::get_if<twinray::Instance<float>>(&o);
    if (!in) continue;
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, asset);
    float xfm[12];
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 3; ++r) xfm[3 * c + r] = static_cast<float>(in->to_world[c][r]);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
    rtcCommitGeometry(g);
    rtcAttachGeometry(top, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(top);
  double ms = twinray_bench::ms_since(t0);
  rtcReleaseScene(top);
  return ms;
}

// The asset (every triangle of the scene's first asset) as a committed Embree scene.
RTCScene embree_asset(RTCDevice device, const twinray::Scene<float>& scene) {
  const auto& mesh = std::get<twinray::Mesh<float>>(scene.assets[0].objects[0]);
  std::vector<float> verts;
  std::vector<unsigned> tris;
  for (const auto& v : mesh.vertices) verts.insert(verts.end(), {v.x, v.y, v.z});
  for (const auto& f : mesh.triangles)
    for (int k = 0; k < 3; ++k) tris.push_back(static_cast<unsigned>(f[k]));
  RTCScene s = rtcNewScene(device);
  embree_world::attach_triangles(device, s, verts, tris);
  rtcCommitScene(s);
  return s;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  long long k = 10000, n = 1000000, moving = 1000;
  int frames = 50, runs = 7;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i], v = argv[i + 1];
    if (a == "--instances")
      k = twinray_bench::parse_count(v);
    else if (a == "--triangles")
      n = twinray_bench::parse_count(v);
    else if (a == "--moving")
      moving = twinray_bench::parse_count(v);
    else if (a == "--frames")
      frames = std::atoi(v.c_str());
    else if (a == "--runs")
      runs = std::atoi(v.c_str());
    else {
      std::cerr << "instance_bench: unknown option " << a << "\n";
      return 2;
    }
  }
  if (k < 2 || n < 1 || moving < 1 || frames < 1 || runs < 1) {
    std::cerr << "instance_bench: --instances >= 2, --triangles, --moving, --frames and --runs "
                 ">= 1\n";
    return 2;
  }
  std::cout << "machine: " << twinray_bench::machine_description() << "\n"
            << "threads: " << twinray::thread_count() << "\n";
  using Scene = twinray::Scene<float>;
  auto make = [&](long long count) { return twinray_bench::forest_scene<float>(count, n).scene; };
  // One instance: the asset's packed size.
  double one_bytes = 0;
  {
    Scene one = make(1);
    one_bytes = static_cast<double>(twinray::pack_scene(one).bytes());
  }
  Scene forest = make(k);
  twinray_bench::reset_peak();
  auto t0 = std::chrono::steady_clock::now();
  twinray::PackedScene<float> ps = twinray::pack_scene(forest);
  const double pack_ms = twinray_bench::ms_since(t0);
  const double peak = twinray_bench::peak_mib();
  const double all_bytes = static_cast<double>(ps.bytes());
  const double triangles = static_cast<double>(n) * static_cast<double>(k);
  std::cout << "forest_" << k << "x" << n << ": " << triangles << " triangles placed, "
            << ps.triangles.size() << " packed\n"
            << "  packed: one instance " << one_bytes / (1 << 20) << " MiB, all " << k << " "
            << all_bytes / (1 << 20) << " MiB: " << (all_bytes - one_bytes) / double(k - 1)
            << " bytes per further instance\n"
            << "  pack_scene " << pack_ms << " ms; peak resident " << peak
            << " MiB (the scene's own objects included)\n";

  // The top level alone, against Embree's, alternately.
  std::vector<double> ours, theirs;
#ifdef TWINRAY_BENCH_WITH_EMBREE
  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene asset = embree_asset(device, forest);
#endif
  for (int r = 0; r < runs; ++r) {
    auto u0 = std::chrono::steady_clock::now();
    twinray::update_instances(ps, forest);
    ours.push_back(twinray_bench::ms_since(u0));
#ifdef TWINRAY_BENCH_WITH_EMBREE
    theirs.push_back(embree_top_level_ms(device, asset, forest));
#endif
  }
  std::cout << "  top level of " << k << " instances: twinray " << twinray_bench::median(ours)
            << " ms";
#ifdef TWINRAY_BENCH_WITH_EMBREE
  std::cout << ", Embree " << RTC_VERSION_STRING << " " << twinray_bench::median(theirs)
            << " ms (twinray/Embree " << twinray_bench::median(ours) / twinray_bench::median(theirs)
            << ")";
  rtcReleaseScene(asset);
  rtcReleaseDevice(device);
#endif
  std::cout << " (median of " << runs << ")\n";

  // Moving instances: every one moves every frame; the assets stay packed.
  Scene scene = make(moving);
  twinray::PackedScene<float> moved = twinray::pack_scene(scene);
  const void* asset_triangles = moved.triangles.data();
  std::vector<double> per_frame;
  for (int f = 0; f < frames; ++f) {
    for (auto& o : scene.objects)
      if (auto* in = std::get_if<twinray::Instance<float>>(&o))
        in->to_world[3] += glm::dvec4(0.01, 0.0, 0.005, 0.0);
    auto u0 = std::chrono::steady_clock::now();
    twinray::update_instances(moved, scene);
    per_frame.push_back(twinray_bench::ms_since(u0));
  }
  std::cout << "  " << moving << " moving instances, " << frames
            << " frames: top level per frame median " << twinray_bench::median(per_frame)
            << " ms, largest " << *std::max_element(per_frame.begin(), per_frame.end())
            << " ms; assets "
            << (moved.triangles.data() == asset_triangles ? "packed once" : "PACKED AGAIN") << "\n";
  // What a device that copies the scene gets per moved frame (set_moved_instances): the
  // top level's nodes and the instance array, out of the whole scene.
  const size_t top_level = moved.bvh_nodes.bytes() - moved.top_level_offset() +
                           moved.instances.size() * sizeof(moved.instances[0]);
  std::cout << "  sent to a copying device per moved frame: " << top_level / 1024.0 << " KiB of "
            << moved.bytes() / double(1 << 20) << " MiB\n";
  return 0;
}
