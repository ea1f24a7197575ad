// The cropped form's CPU blend (BasisForm::Cropped, cpu_blend.hpp): each stored layer holds only
// a rectangle, its fill outside. Its T equals the blend of the same basis with whole layers
// (uncropped), on every texel: rectangles at the plane's edges, an empty one (the layer of
// ones), a sun term, a channel without light, any thread count; the double-precision reference
// agrees; and malformed rectangles are refused by name.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {
namespace {

// A lean-like basis of 21 × 13 texels: five source layers, four stored ones (three shadowed, in
// rectangles that touch every edge of the plane, and a layer of ones with an empty rectangle).
BasisImages cropped_basis(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  BasisImages b;
  b.name = "cropped";
  b.width = 21;
  b.height = 13;
  b.layers = 4;
  // Fills exact in half floats, as load_basis makes them (A rounded as the bake stores B).
  b.unoccluded = {0.125, 0.25, 0.1875, 0.05, 0.12};
  b.crops = {LayerCrop{0, 0, 7, 5, 0, 0.125f}, LayerCrop{14, 8, 7, 5, 0, 0.25f}, LayerCrop{3, 2, 15, 11, 0, 0.1875f},
             LayerCrop{0, 0, 0, 0, 0, 1.0f}};
  std::size_t offset = 0;
  for (LayerCrop& c : b.crops) {
    c.offset = offset;
    for (int k = 0; k < c.cols * c.rows; ++k) b.half.push_back(float_to_half(c.fill * unit(rng)));  // B in [0, A]
    offset += static_cast<std::size_t>(c.cols * c.rows);
  }
  // Source layers 0..2 map onto the shadowed layers; 3 and 4 are unshadowed, their A on the ones.
  b.projection = Eigen::MatrixXf::Zero(5, 4);
  b.projection(0, 0) = 1.0f;
  b.projection(1, 1) = 1.0f;
  b.projection(2, 2) = 1.0f;
  b.projection(3, 3) = 0.05f;
  b.projection(4, 3) = 0.12f;
  return b;
}

std::vector<Eigen::Vector3d> sky() { return {{1, 2, 0.5}, {3, 1, 0.2}, {0.5, 0.5, 0.1}, {2, 2, 0.0}, {1, 0, 0.0}}; }

TEST(CroppedBlend, EqualsTheBlendOfWholeLayersOnEveryTexel) {
  const BasisImages cropped = cropped_basis(3);
  const BasisImages whole = uncropped(cropped);
  ASSERT_FALSE(whole.cropped());
  ASSERT_EQ(whole.half.size(), whole.texel_count() * 4);
  EXPECT_LT(cropped.half.size(), whole.half.size() / 2);
  // value() reads either form alike.
  for (int layer = 0; layer < 4; ++layer) {
    for (int row = 0; row < 13; ++row) {
      for (int col = 0; col < 21; ++col) {
        ASSERT_EQ(cropped.value(layer, col, row), whole.value(layer, col, row)) << layer << " " << col << " " << row;
      }
    }
  }
  std::vector<float> visibility(cropped.texel_count());
  for (std::size_t k = 0; k < visibility.size(); ++k) visibility[k] = static_cast<float>(k % 3) / 2.0f;
  const SunLight sun{Vec3(0.2, 0.1, 1.0).normalized(), Eigen::Vector3d(4, 3, 0)};  // no blue: that channel's light is the sky's
  for (const bool with_sun : {false, true}) {
    const std::optional<SunLight> s = with_sun ? std::optional<SunLight>(sun) : std::nullopt;
    const BlendWeights w = blend_weights(cropped, sky(), s);
    const BlendWeights w_whole = blend_weights(whole, sky(), s);
    const std::span<const float> v = with_sun ? std::span<const float>(visibility) : std::span<const float>();
    std::vector<float> T_whole(3 * whole.texel_count());
    blend_cpu(whole, w_whole, v, T_whole);
    std::vector<double> reference(T_whole.size());
    blend_reference(cropped, sky(), s, v, reference);
    for (const int threads : {1, 2, 3}) {
      BlendOptions options;
      options.threads = threads;
      std::vector<float> T(3 * cropped.texel_count());
      blend_cpu(cropped, w, v, T, options);
      for (std::size_t k = 0; k < T.size(); ++k) {
        // The cropped sum adds the fills first and w·(B − fill) after: float rounding apart.
        ASSERT_NEAR(T[k], T_whole[k], 2e-6) << "value " << k << ", " << threads << " thread(s), sun " << with_sun;
        ASSERT_NEAR(T[k], reference[k], 2e-6) << "value " << k;
        ASSERT_TRUE(T[k] >= 0.0f && T[k] <= 1.0f);
      }
    }
  }
}

// A plane wide enough that the blend cuts it into several bands of rows (32 Ki texels each), with
// rectangles across the bands' borders and overlapping in every way four layers can.
TEST(CroppedBlend, SeveralBandsAndOverlappingSpansBlendAsWholeLayers) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::uniform_int_distribution<int> col(0, 1023), row(0, 99);
  BasisImages b;
  b.name = "bands";
  b.width = 1024;
  b.height = 100;
  b.layers = 9;
  std::vector<Eigen::Vector3d> S;
  for (int l = 0; l < b.layers; ++l) {
    const float a = 0.0625f * static_cast<float>(1 + l % 3);  // exact in half floats
    b.unoccluded.push_back(a);
    S.emplace_back(1.0 + l, 0.5 * l, 2.0);
    const int c0 = col(rng), c1 = col(rng), r0 = row(rng), r1 = row(rng);
    LayerCrop c{std::min(c0, c1), std::min(r0, r1), std::abs(c1 - c0) + 1, std::abs(r1 - r0) + 1, b.half.size(), a};
    for (int k = 0; k < c.cols * c.rows; ++k) b.half.push_back(float_to_half(a * unit(rng)));
    b.crops.push_back(c);
  }
  const BasisImages whole = uncropped(b);
  const BlendWeights w = blend_weights(b, S, std::nullopt);
  std::vector<float> T_whole(3 * whole.texel_count());
  blend_cpu(whole, blend_weights(whole, S, std::nullopt), {}, T_whole);
  for (const int threads : {1, 2}) {
    for (const bool simd : {true, false}) {
      BlendOptions options;
      options.threads = threads;
      options.use_simd = simd;
      std::vector<float> T(T_whole.size());
      blend_cpu(b, w, {}, T, options);
      for (std::size_t k = 0; k < T.size(); ++k) {
        ASSERT_NEAR(T[k], T_whole[k], 2e-6) << "value " << k << ", " << threads << " thread(s), simd " << simd;
      }
    }
  }
}

TEST(CroppedBlend, AChannelWithoutLightIsOneAndBadVisibilityIsRefused) {
  const BasisImages cropped = cropped_basis(5);
  std::vector<Eigen::Vector3d> S = sky();
  for (auto& s : S) s.z() = 0.0;  // no blue anywhere
  const BlendWeights w = blend_weights(cropped, S, std::nullopt);
  ASSERT_TRUE(w.no_light[2]);
  std::vector<float> T(3 * cropped.texel_count());
  blend_cpu(cropped, w, {}, T);
  for (std::size_t k = 2; k < T.size(); k += 3) ASSERT_EQ(T[k], 1.0f);

  const SunLight sun{Vec3(0, 0, 1), Eigen::Vector3d(1, 1, 1)};
  const BlendWeights ws = blend_weights(cropped, sky(), sun);
  std::vector<float> bad(cropped.texel_count(), 0.5f);
  bad[100] = std::nanf("");
  try {
    blend_cpu(cropped, ws, bad, T);
    FAIL() << "NaN visibility accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sun_visibility"), std::string::npos) << e.what();
  }
}

TEST(CroppedBlend, MalformedRectanglesAreRefusedByName) {
  const auto refused = [](const BasisImages& b) {
    try {
      (void)blend_weights(b, sky(), std::nullopt);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  BasisImages outside = cropped_basis(7);
  outside.crops[1].col = 15;  // 15 + 7 > 21
  EXPECT_NE(refused(outside).find("crops"), std::string::npos);
  BasisImages short_data = cropped_basis(7);
  short_data.half.pop_back();
  EXPECT_NE(refused(short_data).find("rectangles"), std::string::npos);
  BasisImages missing = cropped_basis(7);
  missing.crops.pop_back();
  EXPECT_NE(refused(missing).find("crops"), std::string::npos);
}

}  // namespace
}  // namespace skylit::blend
