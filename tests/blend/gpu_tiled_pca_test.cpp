// The GPU blend of a tiled (clustered PCA) basis: every texel sums its own tile's weights over
// the slices all tiles share, as blend_cpu does, on a small synthetic basis whose last column
// and row of tiles are narrower than the rest.
#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../support/gl_suite.hpp"
#include "gpu_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend {
namespace {

constexpr int kWidth = 40;
constexpr int kHeight = 24;
constexpr int kTile = 16;        // 3 × 2 tiles; the last column 8 wide, the last row 8 high
constexpr int kLayers = 5;       // stored layers (per tile: a mean and four eigen-images)
constexpr int kSourceLayers = 7;

// A tiled PCA basis: stored layer 0 (the "mean") in [mean_low, mean_high], the others in
// [-1, 1] (or in [mean_low, mean_high] too when `positive`); A in [0.1, 0.3]; the projection is
// filled in by the caller.
BasisImages tiled_basis(std::mt19937& rng, float mean_low, float mean_high, bool positive) {
  BasisImages basis;
  basis.name = "tiled";
  basis.width = kWidth;
  basis.height = kHeight;
  basis.layers = kLayers;
  basis.tile = kTile;
  std::uniform_real_distribution<float> mean(mean_low, mean_high);
  std::uniform_real_distribution<float> signed_unit(-1.0f, 1.0f);
  const std::size_t texels = basis.texel_count();
  basis.half.resize(texels * kLayers);
  for (std::size_t l = 0; l < kLayers; ++l) {
    for (std::size_t k = 0; k < texels; ++k) {
      const float value = (l == 0 || positive) ? mean(rng) : signed_unit(rng);
      basis.half[l * texels + k] = float_to_half(value);
    }
  }
  std::uniform_real_distribution<double> unoccluded(0.1, 0.3);
  for (int l = 0; l < kSourceLayers; ++l) basis.unoccluded.push_back(unoccluded(rng));
  basis.normal = Vec3::UnitZ();
  basis.layers_per_face = 1;
  basis.projection = Eigen::MatrixXf::Zero(kSourceLayers, basis.tile_count() * kLayers);
  return basis;
}

std::vector<Eigen::Vector3d> sky(std::mt19937& rng) {
  std::uniform_real_distribution<double> radiance(0.5, 2.0);
  std::vector<Eigen::Vector3d> S;
  for (int l = 0; l < kSourceLayers; ++l) S.emplace_back(radiance(rng), radiance(rng), radiance(rng));
  return S;
}

std::vector<float> cpu_blend(const BasisImages& basis, const BlendWeights& w) {
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, {}, T);
  return T;
}

GpuBlendOptions float_options(bool packed) {
  GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
  options.pack_layers = packed;
  return options;
}

class GpuTiledPca : public skylit::test::GlSuite {};

TEST_F(GpuTiledPca, MatchesTheCpuBlendAndTheReference) {
  std::mt19937 rng(17);
  BasisImages basis = tiled_basis(rng, 0.4f, 0.6f, false);
  ASSERT_EQ(basis.tiles_x(), 3);
  ASSERT_EQ(basis.tiles_y(), 2);
  ASSERT_EQ(basis.tile_count(), 6);
  // Row l of tile t: A_l · (1, P_{l,1..4}) with small P, so that T = B_0 + Σ_k u_k B_k stays
  // inside [0, 1] (no clamping hides a difference) while each tile has its own weights.
  std::uniform_real_distribution<float> eigen(-0.1f, 0.1f);
  for (int t = 0; t < basis.tile_count(); ++t) {
    for (int l = 0; l < kSourceLayers; ++l) {
      const auto a = static_cast<float>(basis.unoccluded[static_cast<std::size_t>(l)]);
      basis.projection(l, t * kLayers) = a;
      for (int k = 1; k < kLayers; ++k) basis.projection(l, t * kLayers + k) = a * eigen(rng);
    }
  }
  const std::vector<Eigen::Vector3d> S = sky(rng);
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  ASSERT_EQ(w.face.size(), static_cast<std::size_t>(basis.tile_count() * kLayers));
  const std::vector<float> expected = cpu_blend(basis, w);
  std::vector<double> reference(3 * basis.texel_count());
  blend_reference(basis, S, std::nullopt, {}, reference);
  for (const double r : reference) {
    ASSERT_GT(r, 0.0);
    ASSERT_LT(r, 1.0);
  }
  for (const bool packed : {false, true}) {
    GpuBlender blender(basis, float_options(packed));
    EXPECT_EQ(blender.tile_count(), 6);
    ASSERT_TRUE(blender.blend(w));
    EXPECT_EQ(blender.summed_slices(), packed ? 2 : kLayers);
    EXPECT_EQ(blender.summed_layers(), static_cast<int>(w.active.size()));
    EXPECT_EQ(blender.skipped_layers(), 0);
    const std::vector<float> T = blender.read_back();
    ASSERT_EQ(T.size(), expected.size());
    double worst_cpu = 0.0;
    double worst_reference = 0.0;
    for (std::size_t k = 0; k < T.size(); ++k) {
      worst_cpu = std::max(worst_cpu, std::abs(static_cast<double>(T[k]) - static_cast<double>(expected[k])));
      worst_reference = std::max(worst_reference, std::abs(static_cast<double>(T[k]) - reference[k]));
    }
    EXPECT_LE(worst_cpu, 1e-5) << (packed ? "packed" : "one layer per slice");
    EXPECT_LE(worst_reference, 1e-4) << (packed ? "packed" : "one layer per slice");
    // The same weights again: nothing changed, nothing to do.
    EXPECT_FALSE(blender.blend(w));
  }
}

TEST_F(GpuTiledPca, EachTileReadsItsOwnWeights) {
  std::mt19937 rng(23);
  const BasisImages base = tiled_basis(rng, 0.2f, 0.9f, true);
  const std::vector<Eigen::Vector3d> S = sky(rng);
  for (int tile = 0; tile < base.tile_count(); ++tile) {
    // Only tile `tile` sees any light, through one of its layers (u = 1 there): T = B_layer in
    // that tile's texels, exactly 0 everywhere else.
    BasisImages basis = base;
    const int layer = tile % kLayers;
    for (int l = 0; l < kSourceLayers; ++l) {
      basis.projection(l, tile * kLayers + layer) = static_cast<float>(basis.unoccluded[static_cast<std::size_t>(l)]);
    }
    const BlendWeights w = blend_weights(basis, S, std::nullopt);
    ASSERT_EQ(w.active.size(), 1u);
    EXPECT_EQ(w.active[0], tile * kLayers + layer);
    const std::vector<float> expected = cpu_blend(basis, w);
    for (const bool packed : {false, true}) {
      GpuBlender blender(basis, float_options(packed));
      ASSERT_TRUE(blender.blend(w));
      EXPECT_EQ(blender.summed_slices(), 1);
      EXPECT_EQ(blender.summed_layers(), 1);
      const std::vector<float> T = blender.read_back();
      ASSERT_EQ(T.size(), expected.size());
      int lit = 0;
      int wrong = 0;
      for (int row = 0; row < kHeight; ++row) {
        for (int col = 0; col < kWidth; ++col) {
          const std::size_t k = static_cast<std::size_t>(row) * kWidth + static_cast<std::size_t>(col);
          const bool inside = basis.tile_of(col, row) == tile;
          for (std::size_t c = 0; c < 3; ++c) {
            const float t = T[3 * k + c];
            const bool ok = inside ? (t > 0.0f && t <= 1.0f && std::abs(t - expected[3 * k + c]) <= 1e-5f)
                                   : t == 0.0f;
            if (!ok) {
              ++wrong;
            } else if (inside) {
              ++lit;
            }
          }
        }
      }
      const int tile_w = std::min(kTile, kWidth - (tile % basis.tiles_x()) * kTile);
      const int tile_h = std::min(kTile, kHeight - (tile / basis.tiles_x()) * kTile);
      EXPECT_EQ(wrong, 0) << "tile " << tile << (packed ? " packed" : " one layer per slice");
      EXPECT_EQ(lit, 3 * tile_w * tile_h) << "tile " << tile;
    }
  }
}

TEST_F(GpuTiledPca, WeightsOfTheWrongSizeAreInputErrors) {
  std::mt19937 rng(31);
  BasisImages tiled = tiled_basis(rng, 0.4f, 0.6f, false);
  for (int l = 0; l < kSourceLayers; ++l) {
    for (int k = 0; k < tiled.projection.cols(); ++k) tiled.projection(l, k) = 0.1f;
  }
  // The same images untiled: one projection of kLayers columns, weights for one tile only.
  BasisImages untiled = tiled;
  untiled.tile = 0;
  untiled.projection = tiled.projection.leftCols(kLayers);
  const std::vector<Eigen::Vector3d> S = sky(rng);
  const BlendWeights untiled_weights = blend_weights(untiled, S, std::nullopt);
  ASSERT_EQ(untiled_weights.face.size(), static_cast<std::size_t>(kLayers));
  GpuBlender blender(tiled, float_options(true));
  try {
    blender.blend(untiled_weights);
    FAIL() << "weights for an untiled basis were accepted by a tiled one";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("weights.face"), std::string::npos) << e.what();
  }
  // And the other way round: a tiled set of weights for the untiled blender.
  const BlendWeights tiled_weights = blend_weights(tiled, S, std::nullopt);
  GpuBlender untiled_blender(untiled, float_options(true));
  EXPECT_THROW(untiled_blender.blend(tiled_weights), InputError);
  EXPECT_TRUE(blender.blend(tiled_weights));
}

}  // namespace
}  // namespace skylit::blend
