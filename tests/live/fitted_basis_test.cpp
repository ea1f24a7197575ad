// A fitted dome basis in the live service: the tests' site baked with `dome.basis: quadratics`
// (six quadratic Bernstein functions per face, so 6 × 40 layers at ν = 2), its site and bake in
// the config, the blend on the CPU and on the GPU. The service estimates S with the bake's basis
// (six radiances per face) and blends the full form; its frames are checked against the
// compositor driven directly with blend_cpu's T of that form for the same sky.
// Measured figures are printed ("measured:" lines).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "service_blend_check.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::live_test {
namespace {

// The tests' site (BakedSite's model and planes) with the quadratics basis, baked once per
// program into a temporary folder: site.yaml, tower.glb and bake/.
struct QuadraticsSite {
  test::TempDir dir{"skylit-quadratics-"};
  double bake_seconds = 0;

  QuadraticsSite() {
    const BakedSite& baked = BakedSite::get();
    fs::copy_file(baked.dir / "tower.glb", dir / "tower.glb");
    std::ostringstream in;
    in << std::ifstream(baked.dir / "site.yaml").rdbuf();
    std::string text = in.str();
    const std::string dome = "dome:\n  frequency: 2\n";
    const std::size_t at = text.find(dome);
    if (at == std::string::npos) throw std::runtime_error("the tests' site.yaml has no 'dome: frequency: 2'");
    text.replace(at, dome.size(), dome + "  basis: quadratics\n");
    std::ofstream(dir / "site.yaml") << text;
    baker::BakeOptions options;
    options.site_file = dir / "site.yaml";
    options.out_dir = dir / "bake";
    options.samples = 16;  // the quadratics basis needs at least 6 directions per face
    options.method = "raytrace";
    options.previews = false;
    std::FILE* quiet = std::fopen("/dev/null", "w");
    const auto start = std::chrono::steady_clock::now();
    baker::run_bake(options, quiet);
    bake_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fclose(quiet);
  }
  QuadraticsSite(const QuadraticsSite&) = delete;
  QuadraticsSite& operator=(const QuadraticsSite&) = delete;

  static const QuadraticsSite& get() {
    static const std::unique_ptr<QuadraticsSite> site = std::make_unique<QuadraticsSite>();
    return *site;
  }
};

void expect_service_blends_the_quadratics_bake(const std::string& device) {
  const QuadraticsSite& fitted = QuadraticsSite::get();
  const Rig rig;
  ServiceBlendSetup setup;
  setup.bake_dir = fitted.dir / "bake";
  setup.site_file = fitted.dir / "site.yaml";
  setup.blend = "blend:\n  device: " + device + "\n";
  setup.form = blend::BasisForm::Full;
  setup.label = "dome.basis quadratics, blend.basis full";
  ServiceBlendResult run;
  ASSERT_NO_FATAL_FAILURE(check_service_blend(rig, setup, run));

  const bake_format::Manifest& manifest = run.manifest;
  ASSERT_EQ(manifest.plan.basis, geom::DomeBasis::Quadratics);
  ASSERT_EQ(manifest.plan.frequency, 2);
  EXPECT_EQ(manifest.faces.size(), 40u);
  const nlohmann::json& blend = run.status["blend"];
  EXPECT_EQ(blend["basis"], "full") << blend.dump(2);
  EXPECT_EQ(blend["device"], device) << blend.dump(2);
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    EXPECT_EQ(blend["planes"][j]["layers"], 6 * 40) << manifest.planes[j].plane.name;
  }
  std::printf("measured: quadratics bake of the tests' site (16 samples per face, raytrace): %.1f s, %zu layers\n",
              fitted.bake_seconds, manifest.layer_count());
}

TEST(LiveFittedBasis, QuadraticsBakeBlendsOnTheCpuAsTheDirectComposite) { expect_service_blends_the_quadratics_bake("cpu"); }

TEST(LiveFittedBasis, QuadraticsBakeBlendsOnTheGpuAsTheDirectComposite) { expect_service_blends_the_quadratics_bake("gpu"); }

}  // namespace
}  // namespace skylit::live_test
