// End-to-end tests of skylit-bake: runs the program as a user would and checks what it writes.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/scene/site.hpp"
#include "../support/fixture_cache.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using skylit::geom::Vec3;

namespace {

using skylit::cli_test::kSource;
using skylit::cli_test::Result;
using skylit::cli_test::TempDir;

const fs::path kBake = skylit::cli_test::kBin / "skylit-bake";
Result run(const std::string& args) { return skylit::cli_test::run_program(kBake, args); }

void write_text(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

// A 2 m cube standing on the ground at the origin (x, y in [-1, 1], z in [0, 2]), as OBJ.
constexpr const char* kCubeObj = R"(v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
v -1 -1 2
v 1 -1 2
v 1 1 2
v -1 1 2
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
)";

// ground: 12 m × 12 m around the cube; sky: above everything (never shadowed); wall: a vertical
// plane facing west (normal −x), 1 cm off the cube's west face.
std::string cube_site(const std::string& extra_plane = "", int frequency = 2) {
  // Appended piece by piece: GCC 12 at -O3 warns falsely (-Warray-bounds) on "literal" + string.
  std::string yaml = "scene:\n  model: cube.obj\n  up: z\n  scale: 1.0\ndome:\n  frequency: ";
  yaml += std::to_string(frequency);
  yaml += "\nplanes:\n"
          "  - name: ground\n    origin: [-6, -6, 0.01]\n    u: [12, 0, 0]\n    v: [0, 12, 0]\n    resolution: [48, 48]\n"
          "  - name: sky\n    origin: [-3, -3, 5]\n    u: [6, 0, 0]\n    v: [0, 6, 0]\n    resolution: [8, 8]\n"
          "  - name: wall\n    origin: [-1.01, 1, 0]\n    u: [0, -2, 0]\n    v: [0, 0, 2]\n    resolution: [16, 16]\n";
  yaml += extra_plane;
  return yaml;
}

fs::path make_cube_site(const TempDir& dir, const std::string& extra_plane = "") {
  write_text(dir / "cube.obj", kCubeObj);
  write_text(dir / "site.yaml", cube_site(extra_plane));
  return dir / "site.yaml";
}

// Does the ray from p towards d hit the cube [-1,1]×[-1,1]×[0,2]? (slab test)
bool hits_cube(const Vec3& p, const Vec3& d) {
  double t0 = 1e-9, t1 = 1e9;
  const Vec3 lo(-1, -1, 0), hi(1, 1, 2);
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (p[k] < lo[k] || p[k] > hi[k]) return false;
      continue;
    }
    double a = (lo[k] - p[k]) / d[k], b = (hi[k] - p[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1;
}

// Distance (in parameter space) from the ray to the cube's silhouette: how robust the analytic
// answer is to a small move of the texel centre.
bool near_shadow_edge(const Vec3& p, const Vec3& d, double margin) {
  const bool centre = hits_cube(p, d);
  for (const Vec3& offset : {Vec3(margin, 0, 0), Vec3(-margin, 0, 0), Vec3(0, margin, 0), Vec3(0, -margin, 0)}) {
    if (hits_cube(p + offset, d) != centre) return true;
  }
  return false;
}

}  // namespace

TEST(SkylitBake, BakesVerifiesAndMatchesGeometry) {
  for (const std::string method : {"raster", "raytrace"}) {
    SCOPED_TRACE(method);
    TempDir dir;
    const fs::path site = make_cube_site(dir);
    const Result bake = run(site.string() + " -o " + (dir / "bake").string() + " --method " + method);
    ASSERT_EQ(bake.status, 0) << bake.output;
    EXPECT_NE(bake.output.find("bake complete"), std::string::npos) << bake.output;

    const Result verify = run("verify " + (dir / "bake").string());
    ASSERT_EQ(verify.status, 0) << verify.output;
    EXPECT_NE(verify.output.find("OK"), std::string::npos);

    const skylit::bake_format::Manifest m = skylit::bake_format::read_manifest(dir / "bake");
    ASSERT_EQ(m.faces.size(), 40u);
    ASSERT_EQ(m.planes.size(), 3u);
    const skylit::geom::Dome dome(2);

    // Unoccluded plane: B = A for every face and texel (half-float storage: relative 1e-3).
    const auto sky = skylit::bake_format::read_exr_stack(dir / "bake" / m.planes[1].file);
    ASSERT_EQ(sky.layers, 40);
    for (int i = 0; i < 40; ++i) {
      const double a = m.planes[1].unoccluded[static_cast<std::size_t>(i)];
      for (float b : sky.layer(i)) ASSERT_NEAR(b, a, 1e-3 * a) << "face " << i;
    }

    // Vertical plane: faces wholly behind it have A = B = 0 exactly.
    const auto wall = skylit::bake_format::read_exr_stack(dir / "bake" / m.planes[2].file);
    const Vec3 wall_normal = m.planes[2].plane.normal();
    ASSERT_NEAR(wall_normal.x(), -1.0, 1e-12);
    int behind = 0;
    for (int i = 0; i < 40; ++i) {
      const auto& f = dome.face(i);
      bool all_behind = true;
      for (int v : f.vertex) all_behind &= dome.vertices()[static_cast<std::size_t>(v)].dot(wall_normal) <= 0;
      if (!all_behind) continue;
      ++behind;
      EXPECT_EQ(m.planes[2].unoccluded[static_cast<std::size_t>(i)], 0.0);
      for (float b : wall.layer(i)) ASSERT_EQ(b, 0.0f);
    }
    EXPECT_GE(behind, 15);

    // Ground around the cube, face-centre method: a texel is shadowed exactly when the ray from
    // its centre towards the face centre hits the cube (texels within 0.6 texel of a shadow
    // edge are skipped: the raster engine resolves edges to its shadow-map texel).
    const auto ground = skylit::bake_format::read_exr_stack(dir / "bake" / m.planes[0].file);
    const auto& plane = m.planes[0].plane;
    const double texel = plane.u.norm() / plane.width;
    int checked = 0, shadowed = 0;
    for (int i = 0; i < 40; ++i) {
      const Vec3 d = dome.face(i).centre;
      const double a = m.planes[0].unoccluded[static_cast<std::size_t>(i)];
      for (int row = 0; row < plane.height; ++row) {
        for (int col = 0; col < plane.width; ++col) {
          const Vec3 p = plane.texel_centre(col, row);
          if (near_shadow_edge(p, d, 0.6 * texel)) continue;
          const double expected = hits_cube(p, d) ? 0.0 : a;
          ASSERT_NEAR(ground.layer(i)[static_cast<std::size_t>(row * plane.width + col)], expected, 1e-3 * a)
              << "face " << i << " texel " << col << "," << row;
          ++checked;
          shadowed += expected == 0.0;
        }
      }
    }
    EXPECT_GT(checked, 40 * 48 * 48 * 8 / 10);
    EXPECT_GT(shadowed, 500);

    // Previews are there for the installer.
    EXPECT_TRUE(fs::exists(dir / "bake" / "preview" / "ground.png"));
    EXPECT_TRUE(fs::exists(dir / "bake" / "preview" / "ground_uniform_sky.png"));
    EXPECT_FALSE(fs::exists(dir / "bake" / "parts"));
  }
}

TEST(SkylitBake, ShardsMergeToTheSameBake) {
  TempDir dir;
  const fs::path site = make_cube_site(dir);
  ASSERT_EQ(run(site.string() + " -o " + (dir / "whole").string() + " --no-previews").status, 0);
  const Result a = run(site.string() + " -o " + (dir / "a").string() + " --shard 0/2");
  ASSERT_EQ(a.status, 0) << a.output;
  EXPECT_NE(a.output.find("shard done"), std::string::npos);
  // A shard alone is not a bake.
  const Result partial = run("verify " + (dir / "a").string());
  EXPECT_EQ(partial.status, 1);
  EXPECT_NE(partial.output.find("incomplete"), std::string::npos) << partial.output;
  // The second slice from Slurm's environment.
  {
    const std::string command = "SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_COUNT=2 " + kBake.string() + " " +
                                site.string() + " -o " + (dir / "b").string() + " > /dev/null 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0);
  }
  // Merging one shard only says what is missing.
  const Result missing = run("merge " + (dir / "a").string() + " -o " + (dir / "m1").string());
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.output.find("20 of 40 faces"), std::string::npos) << missing.output;

  const Result merged = run("merge " + (dir / "a").string() + " " + (dir / "b").string() + " -o " +
                            (dir / "merged").string() + " --no-previews");
  ASSERT_EQ(merged.status, 0) << merged.output;
  ASSERT_EQ(run("verify " + (dir / "merged").string()).status, 0);
  const auto whole = skylit::bake_format::read_manifest(dir / "whole");
  const auto joined = skylit::bake_format::read_manifest(dir / "merged");
  for (std::size_t j = 0; j < whole.planes.size(); ++j) {
    const auto x = skylit::bake_format::read_exr_stack(dir / "whole" / whole.planes[j].file);
    const auto y = skylit::bake_format::read_exr_stack(dir / "merged" / joined.planes[j].file);
    EXPECT_EQ(x.data, y.data) << whole.planes[j].plane.name;
  }
}

TEST(SkylitBake, KilledBakeIsNeverValidAndResumes) {
  TempDir dir;
  const fs::path site = make_cube_site(dir);
  const fs::path out = dir / "bake";
  // Slow enough to be caught in the middle: raytrace, 64 samples per face, ν = 4.
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    freopen("/dev/null", "w", stderr);
    execl(kBake.c_str(), kBake.c_str(), site.c_str(), "-o", out.c_str(), "--method", "raytrace", "--samples", "64",
          "--frequency", "4", "--threads", "1", static_cast<char*>(nullptr));
    _exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(out / "parts" / "face_003.part") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the bake finished before it could be interrupted";

  const Result verify = run("verify " + out.string());
  EXPECT_EQ(verify.status, 1) << verify.output;
  EXPECT_NE(verify.output.find("incomplete"), std::string::npos) << verify.output;

  // Without --resume the user is told what to do.
  const Result again = run(site.string() + " -o " + out.string() + " --method raytrace --samples 64 --frequency 4");
  EXPECT_EQ(again.status, 2);
  EXPECT_NE(again.output.find("--resume"), std::string::npos) << again.output;

  // A resume with other options is refused, naming the difference.
  const Result other = run(site.string() + " -o " + out.string() + " --method raytrace --samples 16 --frequency 4 --resume");
  EXPECT_EQ(other.status, 2);
  EXPECT_NE(other.output.find("samples"), std::string::npos) << other.output;

  const Result resumed =
      run(site.string() + " -o " + out.string() + " --method raytrace --samples 64 --frequency 4 --resume --no-previews");
  ASSERT_EQ(resumed.status, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find(" 0 resumed"), std::string::npos) << resumed.output;
  EXPECT_EQ(run("verify " + out.string()).status, 0);
}

TEST(SkylitBake, VerifyDetectsChangedFilesAndOtherVersions) {
  TempDir dir;
  const fs::path site = make_cube_site(dir);
  ASSERT_EQ(run(site.string() + " -o " + (dir / "bake").string() + " --no-previews").status, 0);

  {  // One flipped byte in a plane image.
    const fs::path exr = dir / "bake" / "planes" / "ground.exr";
    std::fstream f(exr, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(exr) / 2));
    char c = 0;
    f.read(&c, 1);
    f.seekp(static_cast<std::streamoff>(fs::file_size(exr) / 2));
    c = static_cast<char>(c ^ 0x5a);
    f.write(&c, 1);
  }
  Result r = run("verify " + (dir / "bake").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("ground.exr"), std::string::npos) << r.output;

  {  // A manifest from a future version.
    const fs::path manifest = dir / "bake" / "manifest.json";
    nlohmann::json j = nlohmann::json::parse(std::ifstream(manifest));
    j["schema_version"] = 99;
    std::ofstream(manifest) << j.dump();
  }
  r = run("verify " + (dir / "bake").string());
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find("version"), std::string::npos) << r.output;
}

TEST(SkylitBake, RefusesToOverwriteWithoutForce) {
  TempDir dir;
  const fs::path site = make_cube_site(dir);
  const std::string args = site.string() + " -o " + (dir / "bake").string() + " --no-previews";
  ASSERT_EQ(run(args).status, 0);
  const Result again = run(args);
  EXPECT_EQ(again.status, 2);
  EXPECT_NE(again.output.find("--force"), std::string::npos) << again.output;
  EXPECT_EQ(run(args + " --force").status, 0);
  EXPECT_EQ(run("verify " + (dir / "bake").string()).status, 0);
}

struct BadInput {
  std::string name;
  std::string site_yaml;    // empty: the good cube site
  std::string extra_args;
  std::string expected;     // in the message
};
// CTest lists a case by its name, not as a dump of the struct's bytes.
void PrintTo(const BadInput& input, std::ostream* os) { *os << input.name; }

class SkylitBakeBadInput : public ::testing::TestWithParam<BadInput> {};

TEST_P(SkylitBakeBadInput, ClearErrorNonZeroExitNoBake) {
  const BadInput& c = GetParam();
  TempDir dir;
  write_text(dir / "cube.obj", kCubeObj);
  write_text(dir / "empty.obj", "# nothing\n");
  write_text(dir / "site.yaml", c.site_yaml.empty() ? cube_site() : c.site_yaml);
  write_text(dir / "a_file", "x");
  std::string out = (dir / "bake").string();
  std::string extra = c.extra_args;
  if (const auto at = extra.find("@DIR@"); at != std::string::npos) extra.replace(at, 5, dir.path().string());
  const bool own_output = extra.find("-o ") != std::string::npos;
  const Result r = run((dir / "site.yaml").string() + (own_output ? "" : " -o " + out) + " " + extra);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(c.expected), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("internal error"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "bake" / "manifest.json"));
}

namespace {
std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}
}  // namespace

INSTANTIATE_TEST_SUITE_P(
    Cases, SkylitBakeBadInput,
    ::testing::Values(
        BadInput{"odd_frequency_option", "", "--frequency 3", "--frequency"},
        BadInput{"odd_frequency_site", replace(cube_site(), "frequency: 2", "frequency: 3"), "", "frequency"},
        BadInput{"zero_frequency_site", replace(cube_site(), "frequency: 2", "frequency: 0"), "", "frequency"},
        BadInput{"zero_resolution_option", "", "--resolution 0x16", "--resolution"},
        BadInput{"huge_resolution_site", replace(cube_site(), "[48, 48]", "[20000, 48]"), "", "resolution"},
        BadInput{"zero_resolution_site", replace(cube_site(), "[48, 48]", "[0, 48]"), "", "resolution"},
        BadInput{"missing_field", replace(cube_site(), "    u: [12, 0, 0]\n", ""), "", "planes[0].u"},
        BadInput{"mistyped_field", replace(cube_site(), "resolution: [48, 48]", "resolutoin: [48, 48]"), "",
                 "resolution"},
        BadInput{"degenerate_plane", replace(cube_site(), "v: [0, 12, 0]", "v: [24, 0, 0]"), "", "planes[0]"},
        BadInput{"nan_plane", replace(cube_site(), "origin: [-6, -6, 0.01]", "origin: [-6, .nan, 0.01]"), "",
                 "planes[0].origin"},
        BadInput{"missing_model", replace(cube_site(), "cube.obj", "nowhere.obj"), "", "nowhere.obj"},
        BadInput{"empty_model", replace(cube_site(), "cube.obj", "empty.obj"), "", "empty.obj"},
        BadInput{"unwritable_output", "", "-o @DIR@/a_file/bake", "a_file"},
        BadInput{"bad_shard", "", "--shard 2/2", "--shard"},
        BadInput{"bad_samples", "", "--samples 0", "--samples"},
        BadInput{"bad_method", "", "--method magic", "--method"}),
    [](const ::testing::TestParamInfo<BadInput>& param_info) { return param_info.param.name; });

TEST(SkylitBake, SampleSiteConfigBakes) {
  // The bundled site, small: what `make demo` runs, at a test-friendly resolution.
  TempDir dir;
  const Result r = run((kSource / "config" / "sample_site.yaml").string() + " -o " + (dir / "bake").string() +
                       " --resolution 32x32");
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_EQ(run("verify " + (dir / "bake").string()).status, 0);
  const auto m = skylit::bake_format::read_manifest(dir / "bake");
  EXPECT_GE(m.planes.size(), 3u);
  for (const auto& p : m.planes) EXPECT_TRUE(fs::exists(dir / "bake" / "preview" / (p.plane.name + ".png")));
}

namespace {

TEST(SkylitBake, ClusteredPcaStoresComponentsPerTile) {
  TempDir dir;
  const Result r = run((kSource / "config" / "sample_site.yaml").string() + " -o " + (dir / "bake").string() +
                       " --frequency 2 --samples 4 --method raytrace --resolution 16x8 --no-previews"
                       " --pca-components 3 --pca-tile 6");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("tiles of 6x6 texels"), std::string::npos) << r.output;
  ASSERT_EQ(run("verify " + (dir / "bake").string()).status, 0);
  const auto m = skylit::bake_format::read_manifest(dir / "bake");
  for (const auto& p : m.planes) {
    ASSERT_TRUE(p.pca.has_value()) << p.plane.name;
    EXPECT_EQ(p.pca->tile, 6) << p.plane.name;
    EXPECT_EQ(p.pca->components, 3) << p.plane.name;
  }
  // Compressed again without tiles: one set for the whole plane.
  ASSERT_EQ(run("compress " + (dir / "bake").string() + " --pca-components 3").status, 0);
  for (const auto& p : skylit::bake_format::read_manifest(dir / "bake").planes) EXPECT_EQ(p.pca->tile, 0) << p.plane.name;
  const Result bad = run("compress " + (dir / "bake").string() + " --pca-components 3 --pca-tile 1");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("pca.tile"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("--pca-tile"), std::string::npos) << bad.output;
}

// skylit-bake walls on the sample site: planes on the flat faces whose vertices miss their light,
// listed, and a site written elsewhere that names the same model; -o the site itself is refused.
TEST(SkylitBake, WallsWritesTheSiteWithPlanesWhereTheVerticesMissTheLight) {
  TempDir dir;
  const fs::path site = kSource / "config" / "sample_site.yaml";
  const Result r = run("walls " + site.string() + " -o " + (dir / "walls.yaml").string() + " --count 2 --texel 0.1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("wall-auto-1:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the vertices' error"), std::string::npos) << r.output;
  // The picture of where the vertices miss the light, beside the site.
  EXPECT_NE(r.output.find("walls.png"), std::string::npos) << r.output;
  EXPECT_GT(fs::file_size(dir / "walls.png"), 1000u);
  const skylit::scene::Site walls = skylit::scene::load_site(dir / "walls.yaml");
  const skylit::scene::Site original = skylit::scene::load_site(site);
  ASSERT_EQ(walls.planes.size(), original.planes.size() + 2);
  EXPECT_EQ(fs::weakly_canonical(walls.model), fs::weakly_canonical(original.model));
  for (std::size_t j = original.planes.size(); j < walls.planes.size(); ++j) {
    EXPECT_EQ(walls.surface_of(j), skylit::scene::PlaneSurface::Virtual);
    EXPECT_EQ(walls.planes[j].name.rfind("wall-auto-", 0), 0u) << walls.planes[j].name;
  }
  const Result same = run("walls " + site.string() + " -o " + site.string());
  EXPECT_EQ(same.status, 2) << same.output;
  EXPECT_NE(same.output.find("that is the site itself"), std::string::npos) << same.output;
}

TEST(SkylitBake, PresetSetsTheBakeAndAnUnknownOneListsTheValidNames) {
  // config/presets.yaml's fast preset: ν=2, corners, 16 samples, a PCA form with 8 components;
  // --samples given too overrides the preset's.
  TempDir dir;
  const Result r = run((kSource / "config" / "sample_site.yaml").string() + " -o " + (dir / "bake").string() +
                       " --preset fast --samples 3 --method raytrace --resolution 16x8 --no-previews");
  ASSERT_EQ(r.status, 0) << r.output;
  const auto m = skylit::bake_format::read_manifest(dir / "bake");
  EXPECT_EQ(m.plan.frequency, 2);
  EXPECT_EQ(m.plan.basis, skylit::geom::DomeBasis::Corners);
  EXPECT_EQ(m.plan.samples, 3);
  for (const auto& p : m.planes) {
    ASSERT_TRUE(p.pca.has_value()) << p.plane.name;
    EXPECT_GE(p.pca->components, 8);
  }

  const Result bad = run((kSource / "config" / "sample_site.yaml").string() + " -o " + (dir / "other").string() +
                         " --preset turbo");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("turbo"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("presets.yaml"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("fast, balanced, accurate"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir / "other" / "manifest.json"));
}

// A preset's light map: its texel, smallest region, narrowest chart and PCA form (alone) reach
// the bake; --light-map-keep-full keeps the full form, --light-map 0 turns the map off, its PCA
// form with it, and --light-map-pca-only without a PCA form is refused.
TEST(SkylitBake, APresetsLightMapReachesTheBakeAndTheCommandLineTurnsItOff) {
  TempDir dir;
  const fs::path presets = dir / "presets.yaml";
  std::ofstream(presets) << "mapped:\n  bake: {frequency: 2, basis: faces, samples: 3, light_map: 0.5, light_map_min_area: 2, "
                            "light_map_min_across: 2, light_map_components: 4, light_map_pca_only: true}\n  live: {basis: full}\n";
  const std::string common = (kSource / "config" / "sample_site.yaml").string() + " --presets " + presets.string() +
                             " --preset mapped --method raytrace --resolution 8x4 --no-previews";
  const Result mapped = run(common + " -o " + (dir / "mapped").string());
  ASSERT_EQ(mapped.status, 0) << mapped.output;
  const auto m = skylit::bake_format::read_manifest(dir / "mapped");
  EXPECT_EQ(m.plan.light_map.texel, 0.5);
  EXPECT_EQ(m.plan.light_map.min_area, 2.0);
  EXPECT_EQ(m.plan.light_map.min_across, 2);
  ASSERT_TRUE(m.light_map.has_value());
  ASSERT_TRUE(m.light_map->pca.has_value());
  EXPECT_EQ(m.light_map->pca->components, 4);
  EXPECT_FALSE(m.light_map->has_full_form());
  EXPECT_FALSE(fs::exists(dir / "mapped" / "light_map_transfer.npy"));

  const Result kept = run(common + " --light-map-keep-full -o " + (dir / "kept").string());
  ASSERT_EQ(kept.status, 0) << kept.output;
  const auto k = skylit::bake_format::read_manifest(dir / "kept");
  ASSERT_TRUE(k.light_map && k.light_map->pca);
  EXPECT_TRUE(k.light_map->has_full_form());
  EXPECT_TRUE(fs::exists(dir / "kept" / "light_map_transfer.npy"));

  const Result plain = run(common + " --light-map 0 -o " + (dir / "plain").string());
  ASSERT_EQ(plain.status, 0) << plain.output;
  EXPECT_FALSE(skylit::bake_format::read_manifest(dir / "plain").light_map.has_value());

  const Result alone = run(common + " --light-map 0 --light-map-pca-only -o " + (dir / "alone").string());
  EXPECT_EQ(alone.status, 2) << alone.output;
  EXPECT_NE(alone.output.find("--light-map-components"), std::string::npos) << alone.output;
  EXPECT_FALSE(fs::exists(dir / "alone" / "manifest.json"));
}

// The defaults a user meets first, on two bakes of the sample site at 16×16 texels a plane, both
// with the default --method (auto): one with -q, one that talks. Made once per build of this
// program (support/fixture_cache.hpp) with what each printed beside it; tests change copies only.
class SkylitBakeDefaults : public ::testing::Test {
 protected:
  struct Bake {
    fs::path dir;
    Result result;
  };
  static Bake bake(const std::string& name) {
    const fs::path root = skylit::test::cached_fixture("cli_bake_defaults", [](const fs::path& folder) {
      const auto record = [&folder](const std::string& run_name, const std::string& options) {
        const Result r = run((kSource / "config" / "sample_site.yaml").string() + " -o " +
                             (folder / run_name).string() + " --resolution 16x16" + options);
        std::ofstream(folder / (run_name + ".status")) << r.status;
        std::ofstream(folder / (run_name + ".output"), std::ios::binary) << r.output;
      };
      record("quiet", " -q");
      record("loud", " --no-previews");
    });
    Bake b{root / name, {}};
    std::ifstream(root / (name + ".status")) >> b.result.status;
    std::ostringstream output;
    output << std::ifstream(root / (name + ".output"), std::ios::binary).rdbuf();
    b.result.output = output.str();
    return b;
  }
};

TEST_F(SkylitBakeDefaults, QuietMeansWarningsAndErrorsOnly) {
  const Bake quiet = bake("quiet"), loud = bake("loud");
  ASSERT_EQ(quiet.result.status, 0) << quiet.result.output;
  EXPECT_EQ(quiet.result.output, "");
  ASSERT_EQ(loud.result.status, 0) << loud.result.output;
  EXPECT_NE(loud.result.output.find("bake complete"), std::string::npos) << loud.result.output;
  // The subcommands too, -q after them as a user types it; verify's report is its result.
  const TempDir dir;
  fs::copy(quiet.dir, dir / "bake", fs::copy_options::recursive);
  const Result compressed = run("compress " + (dir / "bake").string() + " --pca-components 2 -q");
  ASSERT_EQ(compressed.status, 0) << compressed.output;
  EXPECT_EQ(compressed.output, "");
  const Result verified = run("verify " + (dir / "bake").string() + " -q");
  EXPECT_EQ(verified.status, 0) << verified.output;
  EXPECT_NE(verified.output.find("OK"), std::string::npos) << verified.output;
}

TEST_F(SkylitBakeDefaults, AutoPicksTheFastEngineSaysWhyAndRecordsIt) {
  const Bake quiet = bake("quiet"), loud = bake("loud");
  ASSERT_EQ(loud.result.status, 0) << loud.result.output;
  const std::string& output = loud.result.output;
  const std::string said = "method auto: ";
  const auto at = output.find(said);
  ASSERT_NE(at, std::string::npos) << output;
  const std::string line = output.substr(at, output.find('\n', at) - at);
  const std::string method = line.substr(said.size(), line.find_first_of(" ,", said.size()) - said.size());
  // Raytrace where OpenGL ES draws on the CPU (this project's machines: llvmpipe) or not at all,
  // raster on a GPU driver.
  bool software = line.find("no OpenGL ES") != std::string::npos;
  for (const char* renderer : {"llvmpipe", "softpipe", "swrast"}) software |= line.find(renderer) != std::string::npos;
  EXPECT_EQ(method, software ? "raytrace" : "raster") << line;
  // The plan records the engine run, not "auto": resume and merge compare it.
  EXPECT_EQ(skylit::bake_format::read_manifest(loud.dir).plan.method, method);
  EXPECT_EQ(skylit::bake_format::read_manifest(quiet.dir).plan.method, method);
  EXPECT_EQ(quiet.result.output.find(said), std::string::npos) << quiet.result.output;
}

TEST_F(SkylitBakeDefaults, AutoContinuesABakeWithTheEngineItWasStartedWith) {
  // Half the faces with raster, the rest into the same folder with auto: the plans must agree,
  // whatever auto would pick on this machine.
  const TempDir dir;
  const fs::path site = make_cube_site(dir);
  const std::string common = site.string() + " -o " + (dir / "sharded").string() + " --resolution 16x16 --shadow-map 256";
  const Result first = run(common + " --shard 0/2 --method raster -q");
  ASSERT_EQ(first.status, 0) << first.output;
  EXPECT_EQ(first.output, "");
  const Result second = run(common + " --shard 1/2");
  ASSERT_EQ(second.status, 0) << second.output;
  EXPECT_NE(second.output.find("method auto: raster, the engine of the interrupted bake"), std::string::npos)
      << second.output;
  const Result merged =
      run("merge " + (dir / "sharded").string() + " -o " + (dir / "merged").string() + " --no-previews -q");
  ASSERT_EQ(merged.status, 0) << merged.output;
  EXPECT_EQ(merged.output, "");
  EXPECT_EQ(skylit::bake_format::read_manifest(dir / "merged").plan.method, "raster");
}

}  // namespace
