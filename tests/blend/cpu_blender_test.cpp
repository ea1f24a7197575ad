// The service's CPU blend (blend.device cpu): blend_cpu with the GPU blender's two savings, each
// within its bound in units of T, against blend_cpu without them.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/blend/cpu_blender.hpp"
#include "../blend/blend_fixtures.hpp"
#include "skylit/blend/workers.hpp"

namespace skylit::blend {
namespace {

using blend::test::random_scene;

// T of every texel as blend_cpu gives it, with no savings.
std::vector<float> exact(const blend::test::RandomScene& scene, const blend::BlendWeights& weights) {
  std::vector<float> rgb(scene.basis.texel_count() * 3);
  blend::blend_cpu(scene.basis, weights, weights.sun.isZero() ? std::span<const float>() : scene.visibility, rgb);
  return rgb;
}

// Largest |T − exact| over texels and channels.
double max_error(const std::vector<float>& rgba, const std::vector<float>& rgb) {
  double worst = 0;
  for (std::size_t k = 0; k < rgb.size() / 3; ++k) {
    for (std::size_t c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(rgba[4 * k + c]) - rgb[3 * k + c]));
    EXPECT_EQ(rgba[4 * k + 3], 1.0f);
  }
  return worst;
}

TEST(CpuBlender, WithoutSavingsItIsBlendCpu) {
  const auto scene = random_scene(40, 37, 23, 7);
  blend::BlendWorkers workers(2);
  CpuBlender ratios(scene.basis, 0.0, 0.0);
  EXPECT_EQ(ratios.rgba(), nullptr);
  const blend::BlendWeights weights = blend::blend_weights(scene.basis, scene.S, scene.sun);
  ASSERT_FALSE(weights.sun.isZero());
  ASSERT_TRUE(ratios.blend(weights, scene.visibility, 1, &workers));
  ASSERT_NE(ratios.rgba(), nullptr);
  EXPECT_EQ(max_error(*ratios.rgba(), exact(scene, weights)), 0.0);  // the same sums, bit for bit
  // Nothing changed: change_threshold 0 keeps the last T.
  const auto first = ratios.rgba();
  EXPECT_FALSE(ratios.blend(weights, scene.visibility, 1, &workers));
  EXPECT_EQ(ratios.rgba(), first);
  // A new sun visibility always blends.
  EXPECT_TRUE(ratios.blend(weights, scene.visibility, 2, &workers));
  EXPECT_NE(ratios.rgba(), first);
}

TEST(CpuBlender, ChangeThresholdKeepsTheLastTOnlyWithinItsBound) {
  const auto scene = random_scene(40, 37, 23, 11);
  constexpr double kThreshold = 0.01;
  CpuBlender ratios(scene.basis, 0.0, kThreshold);
  ASSERT_TRUE(ratios.blend(blend::blend_weights(scene.basis, scene.S, std::nullopt), {}, 0, nullptr));
  // Skies drifting by small steps: each either keeps the last T, which is then within the
  // threshold of the exact T, or blends anew.
  int kept = 0, ran = 0;
  double worst_kept = 0;
  std::vector<Eigen::Vector3d> S = scene.S;
  for (int step = 0; step < 40; ++step) {
    // Some faces brighten while others dim (a uniform change would cancel in the weights).
    for (std::size_t i = 0; i < S.size(); ++i) S[i] *= 1.0 + 0.01 * std::sin(static_cast<double>(i) + 0.3 * step);
    const blend::BlendWeights weights = blend::blend_weights(scene.basis, S, std::nullopt);
    const double error_before = max_error(*ratios.rgba(), exact(scene, weights));
    if (ratios.blend(weights, {}, 0, nullptr)) {
      ++ran;
      EXPECT_EQ(max_error(*ratios.rgba(), exact(scene, weights)), 0.0);
    } else {
      ++kept;
      worst_kept = std::max(worst_kept, error_before);
    }
  }
  std::printf("measured: change_threshold %.3f: %d skies kept the last T (largest error %.4f), %d blended\n",
              kThreshold, kept, worst_kept, ran);
  EXPECT_GT(kept, 0);
  EXPECT_GT(ran, 0);
  EXPECT_LE(worst_kept, kThreshold + 1e-6);
}

TEST(CpuBlender, SkipThresholdLeavesOutLayersWithinItsBound) {
  for (const double threshold : {0.005, 0.02, 0.05}) {
    SCOPED_TRACE(threshold);
    const auto scene = random_scene(160, 29, 17, 3);
    CpuBlender ratios(scene.basis, threshold, 0.0);
    const blend::BlendWeights weights = blend::blend_weights(scene.basis, scene.S, scene.sun);
    ASSERT_TRUE(ratios.blend(weights, scene.visibility, 1, nullptr));
    const double error = max_error(*ratios.rgba(), exact(scene, weights));
    std::printf("measured: skip_threshold %.3f: %d of %zu active layers left out, max |ΔT| %.4f\n", threshold,
                ratios.skipped_layers(), weights.active.size(), error);
    EXPECT_GT(ratios.skipped_layers(), 0);
    EXPECT_LE(error, threshold + 1e-6);
  }
}

}  // namespace
}  // namespace skylit::blend
