// compress_pca: principal components of a plane's visible fractions. Stacks of known rank come
// back exactly (to half-float rounding), every criterion is met with the smallest K that meets
// it, and layers without light take no part.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "bake_fixtures.hpp"
#include "skylit/bake_format/pca.hpp"

namespace skylit::bake_format {
namespace {

using test::pca_components;
using test::pca_max_error;
using test::pca_variance;

PcaOptions pca_both(int components, double variance) {
  PcaOptions o = pca_components(components);
  o.variance = variance;
  return o;
}

// n layers of w × h whose fractions F_l = clamp(m + Σ_{r<rank} c_{l,r} G_r) span `rank`
// directions around a mean (before the clamp, which the test keeps out of reach), with A_l from
// `unoccluded` (B = A · F).
ImageStack low_rank_stack(int n, int width, int height, int rank, const std::vector<double>& unoccluded,
                          std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const std::size_t texels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  std::vector<std::vector<float>> directions(static_cast<std::size_t>(rank), std::vector<float>(texels));
  for (auto& g : directions) {
    for (float& v : g) v = 0.1f * unit(rng);
  }
  ImageStack stack;
  stack.width = width;
  stack.height = height;
  stack.layers = n;
  stack.data.resize(texels * static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) {
    std::vector<float> c(static_cast<std::size_t>(rank));
    for (float& v : c) v = unit(rng);
    std::span<float> layer = stack.layer(l);
    for (std::size_t x = 0; x < texels; ++x) {
      float f = 0.5f;
      for (int r = 0; r < rank; ++r) f += c[static_cast<std::size_t>(r)] * directions[static_cast<std::size_t>(r)][x];
      layer[x] = static_cast<float>(unoccluded[static_cast<std::size_t>(l)]) * f;
    }
  }
  return stack;
}

// A hard shadow per layer: a disc whose centre moves with the layer, as a dome face's shadow of
// a pole moves with the face (full rank, slowly decaying spectrum).
ImageStack moving_shadows(int n, int width, int height, const std::vector<double>& unoccluded) {
  ImageStack stack;
  stack.width = width;
  stack.height = height;
  stack.layers = n;
  stack.data.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) {
    const double angle = 2.0 * 3.14159265358979 * l / n;
    const double cx = width * (0.5 + 0.3 * std::cos(angle)), cy = height * (0.5 + 0.3 * std::sin(angle));
    std::span<float> layer = stack.layer(l);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const bool shadow = std::hypot(x - cx, y - cy) < 0.15 * width;
        layer[static_cast<std::size_t>(y * width + x)] =
            static_cast<float>(unoccluded[static_cast<std::size_t>(l)]) * (shadow ? 0.1f : 1.0f);
      }
    }
  }
  return stack;
}

std::vector<double> solid_angles(int n) {
  std::vector<double> a(static_cast<std::size_t>(n));
  for (int l = 0; l < n; ++l) a[static_cast<std::size_t>(l)] = 0.05 + 0.1 * (l % 7) / 7.0;
  return a;
}

// A float rounded to the nearest half float (normal range, ties to even), as the bake stores B.
double as_half(float value) {
  if (value == 0.0f) return 0.0;
  int exponent = 0;
  std::frexp(value, &exponent);
  return std::ldexp(std::nearbyint(std::ldexp(static_cast<double>(value), 11 - exponent)), exponent - 11);
}

// max_{l,x} |F_l − F̂_l| recomputed from the stored images and coefficients, against B as stored.
double reconstruction_error(const ImageStack& stack, const std::vector<double>& a, const PcaBasis& pca) {
  double worst = 0.0;
  const std::size_t texels = pca.images.layer(0).size();
  for (int l = 0; l < stack.layers; ++l) {
    if (a[static_cast<std::size_t>(l)] == 0.0) continue;
    for (std::size_t x = 0; x < texels; ++x) {
      double f = pca.images.layer(0)[x];
      for (int k = 0; k < pca.components; ++k) {
        f += static_cast<double>(pca.coefficients[static_cast<std::size_t>(l * pca.components + k)]) *
             pca.images.layer(k + 1)[x];
      }
      const double truth = as_half(stack.layer(l)[x]) / static_cast<double>(static_cast<float>(a[static_cast<std::size_t>(l)]));
      worst = std::max(worst, std::abs(f - truth));
    }
  }
  return worst;
}

TEST(Pca, AStackOfKnownRankComesBackWithThatManyComponents) {
  const int n = 24, rank = 5;
  const std::vector<double> a = solid_angles(n);
  const ImageStack stack = low_rank_stack(n, 32, 20, rank, a, 7);
  const PcaBasis pca = compress_pca(stack, a, pca_max_error(2e-3));
  EXPECT_EQ(pca.components, rank);
  EXPECT_EQ(pca.images.layers, rank + 1);
  EXPECT_EQ(pca.source_layers, n);
  EXPECT_LE(pca.max_error, 2e-3);
  EXPECT_GT(pca.variance_kept, 0.9999);
  // The spectrum says the same: nothing beyond the rank but rounding.
  ASSERT_GT(pca.eigenvalues.size(), static_cast<std::size_t>(rank));
  EXPECT_LT(pca.eigenvalues[static_cast<std::size_t>(rank)], 1e-4 * pca.eigenvalues[static_cast<std::size_t>(rank - 1)]);
  // The reported error is the one the stored form really has.
  EXPECT_NEAR(reconstruction_error(stack, a, pca), pca.max_error, 1e-5);
}

TEST(Pca, KIsTheSmallestThatMeetsTheErrorBound) {
  const int n = 40;
  const std::vector<double> a = solid_angles(n);
  const ImageStack stack = moving_shadows(n, 48, 48, a);
  for (const double bound : {0.3, 0.1}) {
    const PcaBasis pca = compress_pca(stack, a, pca_max_error(bound));
    EXPECT_LE(pca.max_error, bound);
    EXPECT_NEAR(reconstruction_error(stack, a, pca), pca.max_error, 1e-5);
    ASSERT_GT(pca.components, 1);
    const PcaBasis fewer = compress_pca(stack, a, pca_components(pca.components - 1));
    EXPECT_EQ(fewer.components, pca.components - 1);
    EXPECT_GT(fewer.max_error, bound) << "K = " << pca.components << " is not the smallest for " << bound;
  }
}

TEST(Pca, VarianceAndComponentCriteriaAllHold) {
  const int n = 40;
  const std::vector<double> a = solid_angles(n);
  const ImageStack stack = moving_shadows(n, 48, 48, a);
  const PcaBasis by_variance = compress_pca(stack, a, pca_variance(0.9));
  EXPECT_GE(by_variance.variance_kept, 0.9);
  const PcaBasis one_less = compress_pca(stack, a, pca_components(by_variance.components - 1));
  EXPECT_LT(one_less.variance_kept, 0.9);
  // Both criteria: the larger K wins.
  const PcaBasis both = compress_pca(stack, a, pca_both(by_variance.components + 3, 0.9));
  EXPECT_EQ(both.components, by_variance.components + 3);
  EXPECT_LT(both.max_error, by_variance.max_error);
}

TEST(Pca, LayersWithoutLightTakeNoPart) {
  const int n = 12;
  std::vector<double> a = solid_angles(n);
  ImageStack stack = low_rank_stack(n, 16, 16, 3, a, 11);
  // Faces the plane cannot see: A = 0 and B = 0, whatever the rest holds.
  for (const int l : {2, 7}) {
    a[static_cast<std::size_t>(l)] = 0.0;
    std::ranges::fill(stack.layer(l), 0.0f);
  }
  const PcaBasis pca = compress_pca(stack, a, pca_max_error(2e-3));
  EXPECT_EQ(pca.components, 3);
  for (const int l : {2, 7}) {
    for (int k = 0; k < pca.components; ++k) {
      EXPECT_EQ(pca.coefficients[static_cast<std::size_t>(l * pca.components + k)], 0.0f);
    }
  }
  // A plane that sees no layer at all: the mean alone, zero.
  const std::vector<double> dark(static_cast<std::size_t>(n), 0.0);
  std::ranges::fill(stack.data, 0.0f);
  const PcaBasis none = compress_pca(stack, dark, pca_components(4));
  EXPECT_EQ(none.components, 0);
  EXPECT_EQ(none.images.layers, 1);
  EXPECT_EQ(none.max_error, 0.0);
}

TEST(Pca, ImagesAreScaledToUnitPeakAndNamed) {
  const int n = 16;
  const std::vector<double> a = solid_angles(n);
  const PcaBasis pca = compress_pca(moving_shadows(n, 24, 24, a), a, pca_components(4));
  ASSERT_EQ(pca.components, 4);
  for (int k = 1; k <= pca.components; ++k) {
    float peak = 0.0f;
    for (const float v : pca.images.layer(k)) peak = std::max(peak, std::abs(v));
    EXPECT_FLOAT_EQ(peak, 1.0f);
  }
  EXPECT_EQ(pca_layer_names(2), (std::vector<std::string>{"mean", "pc_001", "pc_002"}));
}

// A sky prior picks the components that matter for smooth skies: on layers whose shadows move
// across the dome, the blend of a smooth sky (radiance varying slowly with direction) through K
// components is closer to the full blend than with plain PCA; the reported bound stays honest.
TEST(Pca, ASkyPriorServesSmoothSkiesBetter) {
  const int n = 40;
  const std::vector<double> a = solid_angles(n);
  const ImageStack stack = moving_shadows(n, 48, 48, a);
  std::vector<Vec3> directions;
  for (int l = 0; l < n; ++l) {
    const double azimuth = 2.0 * 3.14159265358979 * l / n;
    directions.emplace_back(std::cos(azimuth), std::sin(azimuth), 0.3);
    directions.back().normalize();
  }
  PcaOptions plain_options = pca_components(4);
  PcaOptions prior_options = plain_options;
  prior_options.sky_correlation_deg = 40.0;
  const PcaBasis plain = compress_pca(stack, a, plain_options, directions);
  const PcaBasis prior = compress_pca(stack, a, prior_options, directions);
  EXPECT_NEAR(reconstruction_error(stack, a, prior), prior.max_error, 1e-5);
  // RMS over texels of T_K − T_full for smooth skies α_l ∝ A_l (1 + cos(φ_l − φ0)), φ0 around the dome.
  const auto sky_error = [&](const PcaBasis& pca) {
    double sum = 0.0;
    int count = 0;
    const std::size_t texels = pca.images.layer(0).size();
    for (int turn = 0; turn < 8; ++turn) {
      std::vector<double> alpha(static_cast<std::size_t>(n));
      double total = 0.0;
      for (int l = 0; l < n; ++l) {
        alpha[static_cast<std::size_t>(l)] = a[static_cast<std::size_t>(l)] * (1.0 + std::cos(2.0 * 3.14159265358979 * (l / double(n) - turn / 8.0)));
        total += alpha[static_cast<std::size_t>(l)];
      }
      for (std::size_t x = 0; x < texels; ++x) {
        double full = 0.0, compressed = 0.0;
        for (int l = 0; l < n; ++l) {
          const double w = alpha[static_cast<std::size_t>(l)] / total;
          full += w * as_half(stack.layer(l)[x]) / a[static_cast<std::size_t>(l)];
          double f = pca.images.layer(0)[x];
          for (int k = 0; k < pca.components; ++k) {
            f += static_cast<double>(pca.coefficients[static_cast<std::size_t>(l * pca.components + k)]) * pca.images.layer(k + 1)[x];
          }
          compressed += w * f;
        }
        sum += (full - compressed) * (full - compressed);
        ++count;
      }
    }
    return std::sqrt(sum / count);
  };
  const double plain_error = sky_error(plain), prior_error = sky_error(prior);
  std::printf("measured: smooth skies through K = 4: RMS %.4f plain, %.4f with a 40° sky prior\n", plain_error, prior_error);
  EXPECT_LT(prior_error, plain_error);
  // Without directions the prior cannot be used.
  EXPECT_THROW(compress_pca(stack, a, prior_options), std::invalid_argument);
}

TEST(Pca, BadOptionsAreRefusedByName) {
  const std::vector<double> a = solid_angles(4);
  const ImageStack stack = low_rank_stack(4, 8, 8, 2, a, 3);
  const auto message = [&](const PcaOptions& options) -> std::string {
    try {
      compress_pca(stack, a, options);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "(accepted)";
  };
  EXPECT_NE(message({}).find("at least one"), std::string::npos);
  EXPECT_NE(message(pca_components(0)).find("pca.components"), std::string::npos);
  EXPECT_NE(message(pca_variance(1.5)).find("pca.variance"), std::string::npos);
  EXPECT_NE(message(pca_max_error(-1.0)).find("pca.max_error"), std::string::npos);
  EXPECT_NE(message(pca_max_error(std::nan(""))).find("pca.max_error"), std::string::npos);
  PcaOptions negative_prior = pca_components(1);
  negative_prior.sky_correlation_deg = -5.0;
  EXPECT_NE(message(negative_prior).find("pca.sky_correlation_deg"), std::string::npos);
  const std::vector<double> short_a(3, 0.1);
  EXPECT_THROW(compress_pca(stack, short_a, pca_components(1)), std::invalid_argument);
  PcaOptions one_texel = pca_components(1);
  one_texel.tile = 1;
  EXPECT_NE(message(one_texel).find("pca.tile"), std::string::npos);
  one_texel.tile = -4;
  EXPECT_NE(message(one_texel).find("pca.tile"), std::string::npos);
}

// Tiled: F_l ≈ μ_t + Σ_k P_{t,l,k} E_k within tile t, from the stored images and coefficients.
double tiled_reconstruction_error(const ImageStack& stack, const std::vector<double>& a, const PcaBasis& pca) {
  double worst = 0.0;
  const int k = pca.components, n = stack.layers;
  for (int l = 0; l < n; ++l) {
    if (a[static_cast<std::size_t>(l)] == 0.0) continue;
    for (int y = 0; y < stack.height; ++y) {
      for (int x = 0; x < stack.width; ++x) {
        const int t = (y / pca.tile) * pca.tiles_x() + x / pca.tile;
        const std::size_t at = static_cast<std::size_t>(y) * static_cast<std::size_t>(stack.width) + static_cast<std::size_t>(x);
        double f = pca.images.layer(0)[at];
        for (int c = 0; c < k; ++c) {
          f += static_cast<double>(pca.coefficients[static_cast<std::size_t>((t * n + l) * k + c)]) * pca.images.layer(c + 1)[at];
        }
        const double truth = as_half(stack.layer(l)[at]) / static_cast<double>(static_cast<float>(a[static_cast<std::size_t>(l)]));
        worst = std::max(worst, std::abs(f - truth));
      }
    }
  }
  return worst;
}

// Each tile of 20 × 20 texels is of rank 2 in directions of its own: the whole plane is of rank 2
// per tile times the tiles, so one set of components needs many, and tiles need two each.
TEST(Pca, TilesOfLowRankComeBackWithTheirOwnComponents) {
  const int n = 24, width = 50, height = 36, tile = 20;  // 3 × 2 tiles, the last column and row narrower
  const std::vector<double> a = solid_angles(n);
  ImageStack stack = low_rank_stack(n, width, height, 2, a, 11);
  // Different directions per tile: stitch tiles from stacks of other seeds.
  for (int t = 1; t < 6; ++t) {
    const ImageStack other = low_rank_stack(n, width, height, 2, a, 11 + static_cast<std::uint32_t>(t));
    for (int l = 0; l < n; ++l) {
      for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
          if ((y / tile) * 3 + x / tile != t) continue;
          const std::size_t at = static_cast<std::size_t>(y * width + x);
          stack.layer(l)[at] = other.layer(l)[at];
        }
      }
    }
  }
  PcaOptions options = pca_max_error(2e-3);
  options.tile = tile;
  const PcaBasis tiled = compress_pca(stack, a, options);
  EXPECT_EQ(tiled.tile, tile);
  EXPECT_EQ(tiled.tile_count(), 6);
  EXPECT_EQ(tiled.components, 2);
  EXPECT_EQ(tiled.images.layers, 3);
  EXPECT_EQ(tiled.coefficients.size(), static_cast<std::size_t>(6 * n * 2));
  EXPECT_LE(tiled.max_error, 2e-3);
  EXPECT_GT(tiled.variance_kept, 0.9999);
  EXPECT_NEAR(tiled_reconstruction_error(stack, a, tiled), tiled.max_error, 1e-5);
  const PcaBasis whole = compress_pca(stack, a, pca_max_error(2e-3));
  std::printf("measured: 6 tiles of rank 2: K = %d tiled, K = %d for the whole plane\n", tiled.components,
              whole.components);
  EXPECT_GE(whole.components, 10);
  // With K fixed, tiles fit better than one set for the whole plane.
  PcaOptions two = pca_components(2);
  const double whole_error = compress_pca(stack, a, two).max_error;
  two.tile = tile;
  EXPECT_LT(compress_pca(stack, a, two).max_error, 0.1 * whole_error);
}

TEST(Pca, EveryTileGetsTheLargestKAnyTileNeeds) {
  // Moving shadows touch the tiles unevenly, and some need more components for the bound than
  // others; all are given the same K, and none does worse than the bound.
  const int n = 40;
  const std::vector<double> a = solid_angles(n);
  const ImageStack stack = moving_shadows(n, 48, 48, a);
  PcaOptions options = pca_max_error(0.1);
  options.tile = 16;
  const PcaBasis tiled = compress_pca(stack, a, options);
  EXPECT_EQ(tiled.tile_count(), 9);
  EXPECT_LE(tiled.max_error, 0.1);
  EXPECT_NEAR(tiled_reconstruction_error(stack, a, tiled), tiled.max_error, 1e-5);
  // At that K the whole plane in one set of components does worse.
  PcaOptions same_k = pca_components(tiled.components);
  const PcaBasis whole = compress_pca(stack, a, same_k);
  std::printf("measured: moving shadows, K = %d: max error %.4f in 9 tiles, %.4f for the whole plane\n",
              tiled.components, tiled.max_error, whole.max_error);
  EXPECT_LT(tiled.max_error, whole.max_error);
  // A tile as large as the plane is no tiling.
  options.tile = 48;
  EXPECT_EQ(compress_pca(stack, a, options).tile, 0);
}

}  // namespace
}  // namespace skylit::bake_format
