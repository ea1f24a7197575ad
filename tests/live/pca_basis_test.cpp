// blend.basis pca: the service blends each plane's PCA form (K + 1 layers) instead of its full
// basis. A copy of the tests' bake, compressed (baker::compress_bake, --pca-variance 0.999), runs
// with blend.basis pca; its shadow ratios agree with the full form's within the manifest's
// max_error, and its frames with the compositor driven directly with the PCA form's T. A bake
// without the PCA form, and 8-bit storage with it, are refused naming the config's field.
// Measured figures are printed ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "skylit/blend/cpu_blender.hpp"
#include "live_fixture.hpp"
#include "service_blend_check.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/base/error.hpp"

namespace skylit::live_test {
namespace {

// A copy of the tests' bake beside the rig, with each plane's PCA form added.
// tile > 0: clustered PCA, each tile of tile × tile texels with its own components.
fs::path compressed_bake(const Rig& rig, int tile = 0) {
  const fs::path copy = rig.dir() / "bake";
  fs::copy(BakedSite::get().dir / "bake", copy, fs::copy_options::recursive);
  bake_format::PcaOptions options;
  options.variance = 0.999;
  options.tile = tile;
  baker::compress_bake(copy, options, std::nullopt, nullptr);
  return copy;
}

std::string load_error(const fs::path& config_file, bool run_service) {
  try {
    const live::LiveConfig config = live::load_live_config(config_file);
    if (run_service) live::Service service(config, quiet_options());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The largest |a − b| over two T images (RGB floats).
double largest_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0;
  for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) worst = std::max(worst, std::abs(double(a[k]) - double(b[k])));
  return worst;
}

// blend.basis lean: the layers that hold a shadow, and one of ones for the unshadowed light.
// Ten frames of the service on the tests' bake with `blend` (YAML) in its config; its status.
nlohmann::json status_of_ten_frames(const std::string& blend, blend::BasisForm expected) {
  RigOptions rig_options;
  const Rig rig(rig_options);
  write_config_with_bake(rig, BakedSite::get().dir / "bake", blend);
  const live::LiveConfig config = rig.config();
  EXPECT_EQ(config.blend.basis, expected);
  live::ServiceOptions options = quiet_options();
  options.frames = 10;
  RunningService running(config, options);
  running.join();
  EXPECT_EQ(running.error(), "");
  return running.status();
}

TEST(LivePcaBasis, LeanFormBlendsOnlyTheShadowedLayers) {
  const nlohmann::json status =
      status_of_ten_frames("blend:\n  device: cpu\n  basis: lean\n", blend::BasisForm::Lean);
  EXPECT_EQ(status["blend"]["basis"], "lean") << status["blend"].dump(2);
  const bake_format::Manifest manifest = bake_format::read_manifest(BakedSite::get().dir / "bake");
  ASSERT_EQ(status["blend"]["planes"].size(), manifest.planes.size());
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    const nlohmann::json& plane = status["blend"]["planes"][j];
    const blend::BasisImages lean = blend::load_basis(BakedSite::get().dir / "bake", manifest, static_cast<int>(j),
                                                        blend::BasisForm::Lean);
    EXPECT_EQ(plane["layers"], lean.layers);
    EXPECT_LE(plane["layers"].get<int>(), static_cast<int>(manifest.layer_count()));
    std::printf("measured: plane '%s': lean form of %d layers for %zu\n", manifest.planes[j].plane.name.c_str(),
                lean.layers, manifest.layer_count());
  }
}

// blend.basis cropped: the lean form, each shadowed layer cropped to the rectangle it shadows;
// the CPU blend reads only the rectangles, with the lean form's layers, bounds and T.
TEST(LivePcaBasis, CroppedFormBlendsOnTheCpuAsTheLeanForm) {
  const nlohmann::json status =
      status_of_ten_frames("blend:\n  device: cpu\n  basis: cropped\n", blend::BasisForm::Cropped);
  EXPECT_EQ(status["blend"]["basis"], "cropped") << status["blend"].dump(2);
  const bake_format::Manifest manifest = bake_format::read_manifest(BakedSite::get().dir / "bake");
  ASSERT_EQ(status["blend"]["planes"].size(), manifest.planes.size());
  const std::vector<Eigen::Vector3d> S(manifest.layer_count(), Eigen::Vector3d(0.9, 1.0, 1.2));
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    SCOPED_TRACE(manifest.planes[j].plane.name);
    const nlohmann::json& plane = status["blend"]["planes"][j];
    const fs::path bake_dir = BakedSite::get().dir / "bake";
    const blend::BasisImages lean = blend::load_basis(bake_dir, manifest, static_cast<int>(j), blend::BasisForm::Lean);
    const blend::BasisImages cropped = blend::load_basis(bake_dir, manifest, static_cast<int>(j), blend::BasisForm::Cropped);
    EXPECT_EQ(plane["layers"], lean.layers);
    EXPECT_EQ(cropped.layers, lean.layers);
    EXPECT_LE(cropped.half.size(), lean.half.size());
    // The bounds the thresholds use: the same per layer, read from the rectangles and fills.
    blend::CpuBlender lean_ratios(lean, 0.0, 0.0), cropped_ratios(cropped, 0.0, 0.0);
    ASSERT_EQ(cropped_ratios.layer_max().size(), lean_ratios.layer_max().size());
    for (std::size_t k = 0; k < lean_ratios.layer_max().size(); ++k) {
      EXPECT_NEAR(cropped_ratios.layer_max()[k], lean_ratios.layer_max()[k], 1e-3 * std::max(1.0f, lean_ratios.layer_max()[k]))
          << "layer " << k;
    }
    // And the same T.
    ASSERT_TRUE(lean_ratios.blend(blend::blend_weights(lean, S, std::nullopt), {}, 1, nullptr));
    ASSERT_TRUE(cropped_ratios.blend(blend::blend_weights(cropped, S, std::nullopt), {}, 1, nullptr));
    EXPECT_LE(largest_difference(*lean_ratios.rgba(), *cropped_ratios.rgba()), 1e-3);
    std::printf("measured: plane '%s': cropped form of %d layers, %zu of the lean form's %zu values\n",
                manifest.planes[j].plane.name.c_str(), cropped.layers, cropped.half.size(), lean.half.size());
  }
  // Any storage: the GPU blend keeps the rectangles cropped, in an atlas of 16 × 16-texel pages
  // (blend/gpu_blend.hpp) whose values, B inside a layer's rectangle and its fill outside, are
  // >= 0 as 8-bit and EAC layers need.
  RigOptions rig_options;
  const Rig rig(rig_options);
  write_config_with_bake(rig, BakedSite::get().dir / "bake", "blend:\n  device: gpu\n  storage: unorm8\n  basis: cropped\n");
  EXPECT_EQ(load_error(rig.config_file(), false), "");
}

// blend.basis cropped on the GPU: the atlas of pages sums the same T as blend_cpu over the cropped
// form; the service's frames against the compositor driven directly with that T.
TEST(LivePcaBasis, CroppedFormBlendsOnTheGpuAsTheDirectComposite) {
  const Rig rig;
  ServiceBlendSetup setup;
  setup.bake_dir = BakedSite::get().dir / "bake";
  setup.blend = "blend:\n  device: gpu\n  basis: cropped\n";
  setup.form = blend::BasisForm::Cropped;
  setup.label = "blend.basis cropped";
  ServiceBlendResult run;
  ASSERT_NO_FATAL_FAILURE(check_service_blend(rig, setup, run));
  const nlohmann::json& blend = run.status["blend"];
  EXPECT_EQ(blend["basis"], "cropped") << blend.dump(2);
  EXPECT_EQ(blend["device"], "gpu") << blend.dump(2);
  for (std::size_t j = 0; j < run.manifest.planes.size(); ++j) {
    const blend::BasisImages cropped =
        blend::load_basis(setup.bake_dir, run.manifest, static_cast<int>(j), blend::BasisForm::Cropped);
    EXPECT_EQ(blend["planes"][j]["layers"], cropped.layers) << run.manifest.planes[j].plane.name;
  }
}

// The service on a compressed bake (tile > 0: clustered) with the blend on `device`, against
// the compositor driven directly with the PCA form's T (the service's blend of the PCA form is
// the same sum as blend_cpu's).
void expect_service_blends_the_pca_form(int tile, const std::string& device) {
  RigOptions rig_options;
  const Rig rig(rig_options);
  ServiceBlendSetup setup;
  setup.bake_dir = compressed_bake(rig, tile);
  setup.blend = "blend:\n  device: " + device + "\n  basis: pca\n";
  setup.form = blend::BasisForm::Pca;
  setup.label = "blend.basis pca, tile " + std::to_string(tile);
  ServiceBlendResult run;
  ASSERT_NO_FATAL_FAILURE(check_service_blend(rig, setup, run));
  ASSERT_EQ(rig.config().blend.basis, blend::BasisForm::Pca);

  // Status: the form and the layers each plane blends (K + 1 of the dome's n).
  const bake_format::Manifest& manifest = run.manifest;
  const nlohmann::json& blend = run.status["blend"];
  EXPECT_EQ(blend["basis"], "pca") << blend.dump(2);
  EXPECT_EQ(blend["device"], device) << blend.dump(2);
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    const bake_format::PlaneRecord& record = manifest.planes[j];
    ASSERT_TRUE(record.pca);
    const nlohmann::json& plane = blend["planes"][j];
    EXPECT_EQ(plane["layers"], record.pca->components + 1);
    EXPECT_EQ(plane["max_error"], record.pca->max_error);
    // A tile as large as the plane is no tiling.
    const bool cut = tile > 0 && (tile < record.plane.width || tile < record.plane.height);
    EXPECT_EQ(record.pca->tile, cut ? tile : 0) << record.plane.name;
    std::printf("measured: plane '%s': PCA form of %d + 1 layers for %zu, max_error %.4g\n", record.plane.name.c_str(),
                record.pca->components, manifest.faces.size(), record.pca->max_error);
    // T of the full form, with the same sky and visibility, within max_error of the PCA form's
    // (max_error bounds |F − F̂| on the stored forms; T blends them in float: a few ulps more).
    const blend::BasisImages full = blend::load_basis(setup.bake_dir, manifest, static_cast<int>(j), blend::BasisForm::Full);
    std::vector<float> full_t(full.texel_count() * 3);
    blend::blend_cpu(full, blend::blend_weights(full, run.sky, run.sun), run.visibility[j], full_t);
    const double difference = largest_difference(run.shadow_ratios[j], full_t);
    std::printf("measured: plane '%s': max |T_pca − T_full| %.4g (manifest max_error %.4g)\n", record.plane.name.c_str(),
                difference, record.pca->max_error);
    EXPECT_LE(difference, record.pca->max_error + 1e-5);
  }
}

TEST(LivePcaBasis, CompressedBakeBlendsItsPcaFormWithinItsMaxError) { expect_service_blends_the_pca_form(0, "cpu"); }

// Clustered PCA on the GPU path: tiles of 16 texels, each with its own weights.
TEST(LivePcaBasis, TiledPcaFormBlendsOnTheGpuWithinItsMaxError) { expect_service_blends_the_pca_form(16, "gpu"); }

TEST(LivePcaBasis, BakeWithoutPcaFormIsRefusedNamingTheFieldAndTheFix) {
  const Rig rig;
  write_config_with_bake(rig, BakedSite::get().dir / "bake", "blend:\n  basis: pca\n");
  ASSERT_FALSE(bake_format::read_manifest(BakedSite::get().dir / "bake").planes.front().pca) << "the tests' bake has a PCA form";
  const std::string message = load_error(rig.config_file(), true);
  EXPECT_NE(message.find(rig.config_file().string()), std::string::npos) << message;
  EXPECT_NE(message.find("blend.basis"), std::string::npos) << message;
  EXPECT_NE(message.find("skylit-bake compress"), std::string::npos) << message;
  EXPECT_NE(message.find("--pca-variance 0.999"), std::string::npos) << message;
}

TEST(LivePcaBasis, EightBitStorageWithPcaIsRefused) {
  const Rig rig;
  write_config_with_bake(rig, BakedSite::get().dir / "bake", "blend:\n  device: gpu\n  storage: unorm8\n  basis: pca\n");
  const std::string message = load_error(rig.config_file(), false);
  EXPECT_NE(message.find(rig.config_file().string()), std::string::npos) << message;
  EXPECT_NE(message.find("blend.storage"), std::string::npos) << message;
  EXPECT_NE(message.find("negative"), std::string::npos) << message;
  EXPECT_NE(message.find("storage: half"), std::string::npos) << message;
}

}  // namespace
}  // namespace skylit::live_test
