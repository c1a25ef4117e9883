// One program of the ISA test (query_isa_test.cpp), built once per instruction set
// (tests/query/CMakeLists.txt): answers a fixed set of queries with the CPU code
// compiled for that set, and prints one hash per precision and BVH width of the hits
// (with extras) and of occluded's answers. Equal lines mean the same bits. The rays are
// random ones, then a camera's rays in one octant with intervals, which the CPU walks
// in packets on the 8-wide tree (its leaves' tests a ray per SIMD lane, each set with
// its own rule for when: device/prelude.h, TR_LANE_GROUP_MIN_RAYS); the program also
// says whether the packets' answers are the single-ray walk's.
#include <cstdio>
#include <variant>
#include <vector>

#include <twinray/backend/cpu.hpp>

#include "query/query_scenes.hpp"

template <class T>
void run(const char* name) {
  // Masks on the objects (k % 4 == 3: 2, else 1), and on the camera's rays below.
  twinray::Scene<T> s = query_test::mixed_scene<T>(11u);
  for (size_t k = 0; k < s.objects.size(); ++k)
    std::visit([&](auto& o) { o.mask = k % 4 == 3 ? 2u : 1u; }, s.objects[k]);
  auto rays = query_test::random_rays<T>(30000, 3u, true);
  for (int j = 0; j < 90; ++j)
    for (int i = 0; i < 110; ++i) {
      const T x = T(-6) + T(i) * T(0.11), y = T(-6) + T(j) * T(0.125);
      auto r = twinray::make_ray<T>(query_test::vec3<T>(8, 9, 10),
                                    query_test::vec3<T>(x - 8, y - 9, T(-16)));
      r.tmin = T((i + j) % 4) * T(0.125);
      r.tmax = (i * j) % 3 == 0 ? T(INFINITY) : r.tmin + T(0.5);
      r.mask = (i / 5 + j) % 3 == 0 ? 2u : 0xffffffffu;
      rays.push_back(r);
    }
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
    const size_t walked =
        twinray::cpu::query_occluded(ps, rays.data(), rays.size(), blocked.data());
    std::vector<twinray::Hit<T>> one_hits(rays.size());
    std::vector<twinray::HitExtra<T>> one_extras(rays.size());
    std::vector<uint8_t> one_blocked(rays.size());
    twinray::cpu::query_intersect(ps, rays.data(), rays.size(), one_hits.data(),
                                  TR_QUERY_SHADING_NORMAL | TR_QUERY_TEXTURE_UV, one_extras.data(),
                                  twinray::cpu::QueryWalk::RayByRay);
    twinray::cpu::query_occluded(ps, rays.data(), rays.size(), one_blocked.data(),
                                 twinray::cpu::QueryWalk::RayByRay);
    const bool same = query_test::same_bytes(hits, one_hits) &&
                      query_test::same_bytes(extras, one_extras) && blocked == one_blocked;
    uint64_t h = query_test::fnv1a(hits.data(), hits.size() * sizeof(hits[0]));
    h = query_test::fnv1a(extras.data(), extras.size() * sizeof(extras[0]), h);
    h = query_test::fnv1a(blocked.data(), blocked.size(), h);
    size_t found = 0;
    for (const auto& x : hits) found += x.object >= 0;
    std::printf("%s width %d: %016llx (%zu hits); %s packets: %s\n", name, width,
                static_cast<unsigned long long>(h), found, walked > 0 ? "with" : "without",
                same ? "the single-ray walk's answers" : "OTHER ANSWERS");
  }
}

int main() {
  run<float>("float");
  run<double>("double");
  return 0;
}
