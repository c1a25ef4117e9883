// `twinray render -o FILE.exr` and `--aov all` (docs/command-line.md): the EXR holds the
// same float bits as the PFM of the same render, --aov all holds every AOV as named
// channels each equal to that AOV's own PFM, and the refusals. In a build without
// OpenEXR, .exr is refused with status 2, naming the missing package.
#include <doctest/doctest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <twinray/io/pfm.hpp>
#ifdef TWINRAY_WITH_OPENEXR
#include <twinray/io/exr.hpp>
#endif

#include "support/float_bits.hpp"
#include "support/subprocess.hpp"

using test_support::contains;
using test_support::float_bits;
using test_support::fresh_folder;
using test_support::listing;
using test_support::Result;
using test_support::run;

namespace {

const std::string kTwinray = TWINRAY_EXE;
const std::string kWork = TWINRAY_TEST_WORK_DIR;
const std::string kScenes = TWINRAY_SCENES_DIR;

Result run_twinray(std::vector<std::string> args, const std::string& cwd) {
  args.insert(args.begin(), kTwinray);
  return run(args, cwd, {});
}

// `twinray render SCENE` at 64x36 on the CPU backend, writing `out`, with `extra` options.
Result render_scene(const std::string& scene, const std::string& dir, const std::string& out,
                    std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {"render", scene,     "-o", out,        "--backend",
                                   "cpu",    "--width", "64", "--height", "36"};
  args.insert(args.end(), extra.begin(), extra.end());
  return run_twinray(args, dir);
}

Result render_demo(const std::string& dir, const std::string& out,
                   std::vector<std::string> extra = {}) {
  return render_scene("demo", dir, out, std::move(extra));
}

}  // namespace

TEST_CASE("exr: --aov all with an output other than .exr is refused (status 2)") {
  std::string dir = fresh_folder(kWork, "exr_refusals");
  for (const char* out : {"x.png", "x.pfm", "x.ppm"}) {
    Result r = render_demo(dir, out, {"--aov", "all"});
    CAPTURE(out);
    CAPTURE(r.err);
    CHECK(r.status == 2);
    CHECK(
        contains(r.err, "--aov all writes named channels into one file; the output must be .exr"));
    CHECK(listing(dir).empty());
  }
  Result r = render_demo(dir, "x.png", {"--aov", "depth"});
  CHECK(r.status == 2);
  CHECK(contains(r.err, "the output must be .pfm or .exr"));
}

#ifdef TWINRAY_WITH_OPENEXR
namespace {

// Whether channel `name` of `exr` holds component c of `pfm`, bit for bit.
void check_channel(const twinray::io::ExrImage& exr, const std::string& name,
                   const twinray::Image<float>& pfm, int c) {
  CAPTURE(name);
  const twinray::io::ExrChannel* ch = exr.find(name);
  REQUIRE(ch != nullptr);
  REQUIRE(exr.width == pfm.width);
  REQUIRE(exr.height == pfm.height);
  size_t differ = 0;
  for (int y = 0; y < pfm.height; ++y)
    for (int x = 0; x < pfm.width; ++x)
      if (float_bits(ch->values[static_cast<size_t>(y) * pfm.width + x]) !=
          float_bits(pfm.pixel(x, y)[c]))
        ++differ;
  CHECK(differ == 0);
}

}  // namespace

TEST_CASE("exr: -o x.exr holds the bits of -o x.pfm of the same render, float and double") {
  std::string dir = fresh_folder(kWork, "exr_render");
  for (const char* precision : {"float", "double"}) {
    CAPTURE(precision);
    Result r = render_demo(dir, "x.exr", {"--precision", precision, "--spp", "2"});
    REQUIRE_MESSAGE(r.status == 0, r.err);
    CHECK(contains(r.out, "x.exr: shaded, 64x36, 2 spp, "));
    r = render_demo(dir, "x.pfm", {"--precision", precision, "--spp", "2"});
    REQUIRE_MESSAGE(r.status == 0, r.err);
    CHECK(listing(dir) == std::vector<std::string>{"x.exr", "x.pfm"});  // no temporary left
    twinray::io::ExrImage exr = twinray::io::read_exr(dir + "/x.exr");
    twinray::Image<float> pfm = twinray::io::read_pfm(dir + "/x.pfm");
    CHECK(exr.channels.size() == 3);
    check_channel(exr, "R", pfm, 0);
    check_channel(exr, "G", pfm, 1);
    check_channel(exr, "B", pfm, 2);
  }
  // A single AOV may go to .exr too: R, G, B as in its PFM.
  Result r = render_demo(dir, "depth.exr", {"--aov", "depth"});
  REQUIRE_MESSAGE(r.status == 0, r.err);
  r = render_demo(dir, "depth.pfm", {"--aov", "depth"});
  REQUIRE_MESSAGE(r.status == 0, r.err);
  twinray::io::ExrImage exr = twinray::io::read_exr(dir + "/depth.exr");
  twinray::Image<float> pfm = twinray::io::read_pfm(dir + "/depth.pfm");
  for (int c = 0; c < 3; ++c) check_channel(exr, std::string(1, "RGB"[c]), pfm, c);
}

TEST_CASE("exr: --aov all writes every AOV as named channels, each equal to its own PFM") {
  // The demo, and models.json, whose textured model has texture coordinates and vertex
  // normals (in the demo uv is 0 and the shading normal is the geometric one).
  for (const std::string& scene : {std::string("demo"), kScenes + "/models.json"}) {
    CAPTURE(scene);
    std::string dir = fresh_folder(kWork, "exr_aov_all");
    Result r = render_scene(scene, dir, "all.exr", {"--aov", "all", "--spp", "2"});
    REQUIRE_MESSAGE(r.status == 0, r.err);
    CHECK(contains(r.out, "all.exr: shaded and every AOV, 64x36, 2 spp, "));
    twinray::io::ExrImage exr = twinray::io::read_exr(dir + "/all.exr");
    std::vector<std::string> names;
    for (const auto& c : exr.channels) names.push_back(c.name);
    CHECK(names == std::vector<std::string>{"B", "G", "N.X", "N.Y", "N.Z", "Ns.X", "Ns.Y", "Ns.Z",
                                            "R", "Z", "object", "uv.U", "uv.V"});
    struct Aov {
      std::string option;                 // "" for the shaded image
      std::vector<std::string> channels;  // component 0, 1, 2 of the PFM
    };
    const std::vector<Aov> aovs = {{"", {"R", "G", "B"}},
                                   {"depth", {"Z"}},
                                   {"normal", {"N.X", "N.Y", "N.Z"}},
                                   {"shading-normal", {"Ns.X", "Ns.Y", "Ns.Z"}},
                                   {"object", {"object"}},
                                   {"uv", {"uv.U", "uv.V"}}};
    for (const Aov& aov : aovs) {
      CAPTURE(aov.option);
      std::vector<std::string> extra = {"--spp", "2"};
      if (!aov.option.empty()) extra = {"--aov", aov.option, "--spp", "2"};
      r = render_scene(scene, dir, "one.pfm", extra);
      REQUIRE_MESSAGE(r.status == 0, r.err);
      twinray::Image<float> pfm = twinray::io::read_pfm(dir + "/one.pfm");
      for (size_t c = 0; c < aov.channels.size(); ++c)
        check_channel(exr, aov.channels[c], pfm, static_cast<int>(c));
    }
    if (scene != "demo") {
      // The channels that are 0 or a copy in the demo carry their own values here.
      CHECK(exr.find("uv.U")->values != std::vector<float>(exr.find("uv.U")->values.size()));
      CHECK(exr.find("Ns.X")->values != exr.find("N.X")->values);
    }
  }
}

TEST_CASE("exr: a failed write gives status 1 and leaves no file") {
  std::string dir = fresh_folder(kWork, "exr_status1");
  std::filesystem::create_directories(dir + "/taken.exr");  // a folder where the file goes
  Result r = render_demo(dir, "taken.exr", {"--aov", "all"});
  CHECK(r.status == 1);
  CHECK(contains(r.err, "taken.exr: cannot replace the file"));
  CHECK(std::filesystem::is_directory(dir + "/taken.exr"));
  CHECK(listing(dir) == std::vector<std::string>{"taken.exr"});  // no temporary left
}
#else
TEST_CASE("exr: a twinray without OpenEXR refuses .exr (status 2), naming the package") {
  MESSAGE("OpenEXR (libopenexr-dev) not found at configure time: testing the refusal only");
  std::string dir = fresh_folder(kWork, "exr_missing");
  for (std::vector<std::string> extra :
       {std::vector<std::string>{}, std::vector<std::string>{"--aov", "all"}}) {
    Result r = render_demo(dir, "x.exr", extra);
    CAPTURE(r.err);
    CHECK(r.status == 2);
    CHECK(contains(r.err, "built without OpenEXR"));
    CHECK(contains(r.err, "libopenexr-dev"));
    CHECK(listing(dir).empty());
  }
}
#endif
