// One program of the ISA test (query_isa_test.cpp), built once per instruction set
// (tests/query/CMakeLists.txt): answers a fixed set of queries with the CPU code
// compiled for that set, and prints one hash per precision and BVH width of the hits
// (with extras) and of occluded's answers. Equal lines mean the same bits.
#include <cstdio>
#include <vector>

#include <twinray/backend/cpu.hpp>

#include "query/query_scenes.hpp"

template <class T>
void run(const char* name) {
  const twinray::Scene<T> s = query_test::mixed_scene<T>(11u);
  const auto rays = query_test::random_rays<T>(30000, 3u, true);
  for (int width : {2, 4, 8}) {
    twinray::PackOptions o;
    o.bvh = twinray::BvhPolicy::Always;
    o.bvh_width = width;
    const auto ps = twinray::pack_scene(s, o);
    std::vector<twinray::Hit<T>> hits(rays.size());
    std::vector<twinray::HitExtra<T>> extras(rays.size());
    std::vector<uint8_t> blocked(rays.size());
    twinray::cpu::query_intersect(ps, rays.data(), rays.size(), hits.data(),
                                  TR_QUERY_SHADING_NORMAL | TR_QUERY_TEXTURE_UV, extras.data());
    twinray::cpu::query_occluded(ps, rays.data(), rays.size(), blocked.data());
    uint64_t h = query_test::fnv1a(hits.data(), hits.size() * sizeof(hits[0]));
    h = query_test::fnv1a(extras.data(), extras.size() * sizeof(extras[0]), h);
    h = query_test::fnv1a(blocked.data(), blocked.size(), h);
    size_t found = 0;
    for (const auto& x : hits) found += x.object >= 0;
    std::printf("%s width %d: %016llx (%zu hits)\n", name, width,
                static_cast<unsigned long long>(h), found);
  }
}

int main() {
  run<float>("float");
  run<double>("double");
  return 0;
}
