// The GPU blend of a cropped basis (BasisImages::cropped()), kept cropped in pages of an atlas
// (gpu_blend.hpp): the same T as blend_cpu on the same basis on every texel, for rectangles of
// every kind on a plane whose size is not a multiple of the page size, in every storage, packed
// and not, with and without the sun; the atlas is far smaller than whole layers and
// gpu_basis_bytes says its size without a context; skip_threshold keeps its bound; and a dome's
// worth of small rectangles works.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../support/gl_suite.hpp"
#include "gpu_test_support.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend {
namespace gpu_cropped_test {  // named, not anonymous: the test program is one unity build

constexpr double kUnitRoundoff = 0x1p-24;
constexpr double kHalfUlpBelowOne = 0x1p-11;

class GpuCropped : public skylit::test::GlSuite {};

// A layer's rectangle, its fill, and the largest value inside (B uniform in [0, top]).
struct Rect {
  int col, row, cols, rows;
  float fill;
  float top;
};

BasisImages cropped_basis(int width, int height, const std::vector<Rect>& rects, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  BasisImages b;
  b.name = "paged";
  b.width = width;
  b.height = height;
  b.layers = static_cast<int>(rects.size());
  for (const Rect& r : rects) {
    LayerCrop c{r.col, r.row, r.cols, r.rows, b.half.size(), r.fill};
    for (int k = 0; k < r.cols * r.rows; ++k) {
      const float pick = unit(rng);
      // Full shadow, full light and anything between, as a bake's layers.
      const float v = pick < 0.2f ? 0.0f : (pick < 0.4f ? r.top : r.top * unit(rng));
      b.half.push_back(float_to_half(v));
    }
    b.crops.push_back(c);
    b.unoccluded.push_back(std::max({static_cast<double>(r.fill), static_cast<double>(r.top), 0.01}));
  }
  return b;
}

// 45 × 37 texels (3 × 3 pages, the last column and row partial): a single texel, rectangles
// across page borders, one at the right and bottom edges, one over the whole plane, a layer the
// sky leaves dark (weight 0), fills of 0 and not, and an empty rectangle (the layer of ones).
BasisImages edge_cases_basis(std::uint32_t seed) {
  return cropped_basis(45, 37,
                       {{20, 20, 1, 1, 0.25f, 0.25f},          // one texel
                        {10, 12, 20, 10, 0.125f, 0.125f},      // across x = 16 and y = 16
                        {38, 30, 7, 7, 0.1875f, 0.1875f},      // at the right and bottom edges
                        {0, 0, 45, 37, 0.5f, 0.09375f},        // the whole plane (its fill nowhere)
                        {5, 5, 8, 8, 0.0625f, 0.0625f},        // weight 0 (S = 0)
                        {0, 30, 12, 7, 0.0f, 0.1f},            // fill 0, at the left and bottom edges
                        {14, 14, 20, 20, 0.09375f, 0.09375f},  // across two borders, fill ≠ 0
                        {0, 0, 0, 0, 1.0f, 0.0f},              // empty: the fill everywhere
                        {31, 0, 14, 3, 0.03125f, 0.03125f}},   // the top-right corner
                       seed);
}

std::vector<Eigen::Vector3d> sky_for(const BasisImages& basis, std::uint32_t seed, int dark_layer) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> radiance(0.2, 3.0);
  std::vector<Eigen::Vector3d> S;
  for (int k = 0; k < basis.layers; ++k) {
    S.emplace_back(radiance(rng), radiance(rng), radiance(rng));
    if (k == dark_layer) S.back().setZero();
  }
  return S;
}

std::vector<float> cpu_blend(const BasisImages& basis, const BlendWeights& w, std::span<const float> visibility) {
  std::vector<float> T(3 * basis.texel_count());
  blend_cpu(basis, w, w.sun.isZero() ? std::span<const float>() : visibility, T);
  return T;
}

double max_abs_difference(std::span<const float> a, std::span<const float> b) {
  double worst = 0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(static_cast<double>(a[k]) - b[k]));
  return worst;
}

// max_x |B_k| per layer, the fill counted where the rectangle leaves any of the plane.
std::vector<double> layer_maxima(const BasisImages& basis) {
  std::vector<double> top(static_cast<std::size_t>(basis.layers), 0.0);
  for (int k = 0; k < basis.layers; ++k) {
    for (int row = 0; row < basis.height; ++row) {
      for (int col = 0; col < basis.width; ++col) {
        top[static_cast<std::size_t>(k)] = std::max(top[static_cast<std::size_t>(k)], std::abs(static_cast<double>(basis.value(k, col, row))));
      }
    }
  }
  return top;
}

// The bound on |T_gpu − T_cpu| for one storage: two fp32 sums of terms adding up to at most
// Σ|w_k| max_k + |w_sun| (the CPU's fills first, the GPU's per tile; a generous factor for the
// different order), plus the storage's quantisation and the output's rounding.
double bound_of(const BasisImages& basis, const BlendWeights& w, const GpuBlender& blender) {
  const std::vector<double> top = layer_maxima(basis);
  double magnitude = 0.0, quantisation = 0.0;
  for (int c = 0; c < 3; ++c) {
    double m = std::abs(w.sun[c]), q = 0.0;
    for (const int i : w.active) {
      const auto k = static_cast<std::size_t>(i);
      m += std::abs(w.face[k][c]) * top[k];
      if (blender.options().storage == BasisStorage::Unorm8) q += std::abs(w.face[k][c]) * top[k] / 510.0;
      if (blender.options().storage == BasisStorage::Eac11) q += std::abs(w.face[k][c]) * blender.eac_error()[k];
    }
    magnitude = std::max(magnitude, m);
    quantisation = std::max(quantisation, q);
  }
  const double summation = 4.0 * static_cast<double>(w.active.size() + 2) * kUnitRoundoff * std::max(magnitude, 1.0);
  const double output = blender.options().output == ShadowRatioFormat::Half ? kHalfUlpBelowOne : 0.0;
  return summation + quantisation + output + (blender.options().storage == BasisStorage::Eac11 ? 1e-5 : 0.0);
}

// Page entries a paged blend of one layer per texel reads: per tile, the active layers whose
// rectangle overlaps it.
int overlapping_active(const BasisImages& basis, const BlendWeights& w) {
  int count = 0;
  for (int ty = 0; ty * kGpuPageSize < basis.height; ++ty) {
    for (int tx = 0; tx * kGpuPageSize < basis.width; ++tx) {
      for (const int i : w.active) {
        const LayerCrop& c = basis.crops[static_cast<std::size_t>(i)];
        if (c.cols == 0 || c.rows == 0) continue;
        const bool x = c.col < (tx + 1) * kGpuPageSize && c.col + c.cols > tx * kGpuPageSize;
        const bool y = c.row < (ty + 1) * kGpuPageSize && c.row + c.rows > ty * kGpuPageSize;
        count += x && y ? 1 : 0;
      }
    }
  }
  return count;
}

// Active layers that are zero everywhere (c_k = 0).
int zero_layers(const BasisImages& basis, const BlendWeights& w) {
  const std::vector<double> top = layer_maxima(basis);
  return static_cast<int>(std::count_if(w.active.begin(), w.active.end(), [&](int i) { return top[static_cast<std::size_t>(i)] == 0.0; }));
}

struct Case {
  BasisStorage storage;
  bool packed;
  ShadowRatioFormat output;
  std::string name() const {
    const char* s = storage == BasisStorage::Half ? "half" : (storage == BasisStorage::Unorm8 ? "8-bit" : "EAC");
    return std::string(s) + (packed ? " packed" : " one layer per texel") +
           (output == ShadowRatioFormat::Float ? ", RGBA32F T" : ", RGBA16F T");
  }
  GpuBlendOptions options() const {
    GpuBlendOptions o = test::blend_options(storage, output);
    o.pack_layers = packed;
    return o;
  }
};

const Case kCases[] = {{BasisStorage::Half, false, ShadowRatioFormat::Float},  {BasisStorage::Half, true, ShadowRatioFormat::Float},
                       {BasisStorage::Half, true, ShadowRatioFormat::Half},    {BasisStorage::Unorm8, false, ShadowRatioFormat::Float},
                       {BasisStorage::Unorm8, true, ShadowRatioFormat::Float}, {BasisStorage::Eac11, false, ShadowRatioFormat::Float},
                       {BasisStorage::Eac11, true, ShadowRatioFormat::Float}};

void expect_matches_cpu(const std::string& what, const BasisImages& basis, const BlendWeights& w,
                        std::span<const float> visibility, bool check_entries) {
  const std::vector<float> expected = cpu_blend(basis, w, visibility);
  std::optional<test::VisibilityTexture> sun_texture;
  if (!w.sun.isZero()) sun_texture.emplace(basis.width, basis.height, visibility);
  for (const Case& c : kCases) {
    SCOPED_TRACE(what + ", " + c.name());
    GpuBlender blender(basis, c.options());
    ASSERT_TRUE(blender.paged());
    EXPECT_GT(blender.pages(), 0);
    EXPECT_TRUE(blender.blend(w, sun_texture ? &sun_texture->texture : nullptr));
    // At threshold 0 only the layers that add nothing anywhere go (an empty rectangle, fill 0).
    EXPECT_EQ(blender.summed_layers() + blender.skipped_layers(), static_cast<int>(w.active.size()));
    EXPECT_EQ(blender.skipped_layers(), zero_layers(basis, w));
    EXPECT_EQ(blender.skipped_bound(), 0.0);
    if (check_entries && !c.packed) {
      EXPECT_EQ(blender.summed_slices(), overlapping_active(basis, w));
    }
    const std::vector<float> T = blender.read_back();
    ASSERT_EQ(T.size(), expected.size());
    const double difference = max_abs_difference(T, expected);
    const double bound = bound_of(basis, w, blender);
    std::printf("measured: %s, %s: %d pages, %d entries read, max |T_gpu - T_cpu| = %.3g (bound %.3g)\n", what.c_str(),
                c.name().c_str(), blender.pages(), blender.summed_slices(), difference, bound);
    EXPECT_LE(difference, bound);
    if (c.storage == BasisStorage::Half && c.output == ShadowRatioFormat::Float) {
      EXPECT_LE(difference, 2e-6);
    }
  }
}

TEST_F(GpuCropped, PagedBlendEqualsTheCpuBlendOnEveryTexel) {
  const BasisImages basis = edge_cases_basis(3);
  const std::vector<Eigen::Vector3d> S = sky_for(basis, 5, 4);
  std::vector<float> visibility(basis.texel_count());
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (float& v : visibility) {
    const float pick = unit(rng);
    v = pick < 0.4f ? 0.0f : (pick < 0.8f ? 1.0f : unit(rng));
  }
  const SunLight sun{Vec3(0.3, 0.2, 1.0).normalized(), Eigen::Vector3d(3.0, 2.5, 2.0)};
  for (const bool with_sun : {false, true}) {
    const BlendWeights w = blend_weights(basis, S, with_sun ? std::optional<SunLight>(sun) : std::nullopt);
    ASSERT_EQ(std::count(w.active.begin(), w.active.end(), 4), 0) << "layer 4's weight is 0";
    ASSERT_EQ(w.sun.isZero(), !with_sun);
    expect_matches_cpu(with_sun ? "45x37 edge cases + sun" : "45x37 edge cases", basis, w, visibility, true);
  }
}

TEST_F(GpuCropped, AtlasIsSmallAndItsSizeIsKnownWithoutAContext) {
  // 40 layers of 6 × 6 texels on a 128 × 96 plane (48 tiles).
  std::vector<Rect> rects;
  std::mt19937 rng(13);
  std::uniform_int_distribution<int> col(0, 122), row(0, 90);
  for (int k = 0; k < 40; ++k) rects.push_back({col(rng), row(rng), 6, 6, 0.125f, 0.125f});
  const BasisImages small = cropped_basis(128, 96, rects, 17);
  const BasisImages whole = uncropped(small);
  const BasisImages edges = edge_cases_basis(19);
  std::vector<Rect> wide_rects;
  for (int k = 0; k < 9; ++k) wide_rects.push_back({k, 2 * k, 100 - 3 * k, 50, 0.25f, 0.25f});
  const BasisImages wide = cropped_basis(130, 70, wide_rects, 23);
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.name());
    const GpuBlender paged(small, c.options());
    const GpuBlender unpaged(whole, c.options());
    EXPECT_TRUE(paged.paged());
    EXPECT_FALSE(unpaged.paged());
    EXPECT_EQ(unpaged.pages(), 0);
    std::printf("measured: 40 layers of 6x6 on 128x96, %s: %zu bytes paged (%d pages), %zu whole\n", c.name().c_str(),
                paged.basis_bytes(), paged.pages(), unpaged.basis_bytes());
    EXPECT_LT(paged.basis_bytes() * 4, unpaged.basis_bytes());
    for (const BasisImages* basis : {&small, &whole, &edges, &wide}) {
      const GpuBlender blender(*basis, c.options());
      EXPECT_EQ(gpu_basis_bytes(*basis, c.options()), blender.basis_bytes()) << basis->width << "x" << basis->height;
    }
  }
}

TEST_F(GpuCropped, SkipThresholdRemovesWholeLayersWithinItsBound) {
  // Rectangles with fills, under a sky whose faces span four decades: the dim ones can go.
  std::vector<Rect> rects;
  std::mt19937 rng(29);
  std::uniform_int_distribution<int> col(0, 63), row(0, 47), size(1, 30);
  for (int k = 0; k < 60; ++k) {
    const int c0 = col(rng), r0 = row(rng);
    const float a = 0.03125f * static_cast<float>(1 + k % 4);  // exact in half floats
    rects.push_back({c0, r0, std::min(size(rng), 64 - c0), std::min(size(rng), 48 - r0), a, a});
  }
  const BasisImages basis = cropped_basis(64, 48, rects, 31);
  std::vector<Eigen::Vector3d> S = sky_for(basis, 37, -1);
  for (std::size_t k = 0; k < S.size(); ++k) S[k] *= std::pow(10.0, -static_cast<double>(k % 4));
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  const std::vector<float> all_layers = cpu_blend(basis, w, {});
  for (const bool packed : {false, true}) {
    for (const double threshold : {0.001, 0.01, 0.05}) {
      GpuBlendOptions options = test::blend_options(BasisStorage::Half, ShadowRatioFormat::Float);
      options.pack_layers = packed;
      options.skip_threshold = threshold;
      GpuBlender blender(basis, options);
      ASSERT_TRUE(blender.blend(w));
      const std::vector<float> T = blender.read_back();
      const double worst = max_abs_difference(T, all_layers);
      std::printf("measured: paged, skip_threshold %.3g, %s: %d of %zu layers skipped (bound %.3g), %d entries read, "
                  "max error %.3g\n",
                  threshold, packed ? "packed" : "one layer per texel", blender.skipped_layers(), w.active.size(),
                  blender.skipped_bound(), blender.summed_slices(), worst);
      EXPECT_GT(blender.skipped_layers(), 0);
      EXPECT_EQ(blender.summed_layers() + blender.skipped_layers(), static_cast<int>(w.active.size()));
      EXPECT_LE(blender.skipped_bound(), threshold);
      EXPECT_LE(worst, blender.skipped_bound() + 1e-6);
    }
  }
}

TEST_F(GpuCropped, SixHundredFortySmallRectanglesMatchTheCpu) {
  std::vector<Rect> rects;
  std::mt19937 rng(41);
  std::uniform_int_distribution<int> col(0, 127), row(0, 95), size(1, 24);
  for (int k = 0; k < 640; ++k) {
    const int c0 = col(rng), r0 = row(rng);
    const float a = 0.0078125f * static_cast<float>(1 + k % 3);
    const bool empty = k % 97 == 0;  // now and then a layer without a rectangle
    rects.push_back({c0, r0, empty ? 0 : std::min(size(rng), 128 - c0), empty ? 0 : std::min(size(rng), 96 - r0),
                     k % 5 == 0 ? 0.0f : a, a});
  }
  const BasisImages basis = cropped_basis(128, 96, rects, 43);
  const std::vector<Eigen::Vector3d> S = sky_for(basis, 47, 100);
  const BlendWeights w = blend_weights(basis, S, std::nullopt);
  ASSERT_GT(w.active.size(), 600u);
  expect_matches_cpu("640 small rectangles on 128x96", basis, w, {}, true);
}

}  // namespace
}  // namespace skylit::blend
