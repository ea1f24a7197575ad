// EAC R11 basis layers: the codec on the CPU (flat and two-level blocks, edges of the image, bad
// values), the driver's decoding against ours, and the GPU blend from EAC layers against the CPU
// blend within the error the blender measured on upload ("measured:" lines).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "blend_fixtures.hpp"
#include "gpu_test_support.hpp"
#include "../support/gl_suite.hpp"
#include "skylit/base/error.hpp"
#include "skylit/blend/eac.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/blend/gpu_blend.hpp"

namespace skylit::blend {
namespace eac_test {  // named, not anonymous: the test program is one unity build

using test::make_basis;
using test::random_scene;

// One 11-bit step is 1/2047; a value rounds to the nearest step, and the unorm16 the driver reads
// ((v << 5) | (v >> 6)) / 65535 is within 1.6e-5 of v / 2047.
constexpr double kHalfStep = 0.5 / 2047.0 + 1.6e-5;

double max_error(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, std::abs(static_cast<double>(a[k]) - b[k]));
  return worst;
}

std::vector<float> round_trip(const std::vector<float>& values, int width, int height) {
  return decode_eac_r11(encode_eac_r11(values, width, height), width, height);
}

TEST(EacCodec, FlatBlocksComeBackWithinHalfAStep) {
  for (const float v : {0.0f, 1.0f, 0.5f, 0.3f, 0.77f, 1e-4f, 0.9999f}) {
    const std::vector<float> values(64, v);
    EXPECT_LE(max_error(round_trip(values, 8, 8), values), kHalfStep) << "value " << v;
  }
}

TEST(EacCodec, ShadowEdgesBetweenZeroAndOneAreExact) {
  // A shadow edge in a layer scaled by its maximum: 0 in umbra, 1 in full light, any direction.
  const int size = 16;
  for (const double angle : {0.0, 0.4, 1.1, 2.0, 2.9}) {
    std::vector<float> values(size * size);
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        values[static_cast<std::size_t>(y * size + x)] = std::cos(angle) * (x - 7.3) + std::sin(angle) * (y - 8.1) > 0 ? 1.0f : 0.0f;
      }
    }
    EXPECT_LE(max_error(round_trip(values, size, size), values), kHalfStep) << "edge at " << angle << " rad";
  }
}

TEST(EacCodec, SmoothAndNoisyLayersStayWithinMeasuredBounds) {
  const int width = 64, height = 48;
  std::vector<float> smooth(width * height), noisy(width * height);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const auto k = static_cast<std::size_t>(y * width + x);
      smooth[k] = static_cast<float>(0.5 + 0.5 * std::sin(0.11 * x) * std::cos(0.07 * y));
      noisy[k] = uniform(rng);
    }
  }
  const double smooth_error = max_error(round_trip(smooth, width, height), smooth);
  const double noisy_error = max_error(round_trip(noisy, width, height), noisy);
  std::printf("measured: EAC R11 max error, smooth layer %.3g (%.2f steps), uniform noise %.3g\n", smooth_error,
              smooth_error * 2047.0, noisy_error);
  // The steepest 4×4 blocks of the smooth layer span about 0.22 (450 steps) and a block has eight
  // levels: an exhaustive search over every table, multiplier and base leaves 27.5 steps there
  // (measured once, off-line); the encoder's search is allowed 30. Noise needs 16 values of 8 levels.
  EXPECT_LE(smooth_error, 30.0 / 2047.0);
  EXPECT_LE(noisy_error, 0.2);
  EXPECT_GT(noisy_error, kHalfStep);  // lossy: a block holds only eight levels
}

TEST(EacCodec, ImageEdgesBadValuesAndSizes) {
  // 5 × 7: partial blocks on the right and at the bottom.
  std::vector<float> values(35);
  for (std::size_t k = 0; k < values.size(); ++k) values[k] = static_cast<float>(k) / 34.0f;
  values[3] = std::numeric_limits<float>::quiet_NaN();
  values[4] = 7.0f;
  values[5] = -2.0f;
  values[6] = std::numeric_limits<float>::infinity();
  const std::vector<std::uint8_t> blocks = encode_eac_r11(values, 5, 7);
  EXPECT_EQ(blocks.size(), eac_block_count(5, 7) * kEacBlockBytes);
  EXPECT_EQ(eac_block_count(5, 7), 4u);
  const std::vector<float> back = decode_eac_r11(blocks, 5, 7);
  ASSERT_EQ(back.size(), values.size());
  for (const float v : back) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f && v <= 1.0f);
  EXPECT_NEAR(back[3], 0.0, 0.05);  // NaN → 0
  EXPECT_NEAR(back[4], 1.0, 0.05);  // clamped
  EXPECT_NEAR(back[5], 0.0, 0.05);
  EXPECT_NEAR(back[6], 1.0, 0.05);
  EXPECT_THROW(encode_eac_r11(values, 6, 7), std::invalid_argument);
  EXPECT_THROW(decode_eac_r11(blocks, 0, 7), std::invalid_argument);
}

class EacBlend : public skylit::test::GlSuite {};

// T from the layers as the driver should decode them: Σ w_i max_i dec_i + w_sun V, clamped.
std::vector<float> decoded_blend(const BasisImages& basis, const BlendWeights& w, std::span<const float> visibility) {
  const std::size_t texels = basis.texel_count();
  std::vector<double> sum(3 * texels, 0.0);
  std::vector<float> b(texels), unit(texels);
  for (const int i : w.active) {
    halves_to_floats(std::span<const std::uint16_t>(basis.half.data() + static_cast<std::size_t>(i) * texels, texels), b);
    float top = 0.0f;
    for (const float v : b) top = std::max(top, std::abs(v));
    for (std::size_t k = 0; k < texels; ++k) unit[k] = top > 0.0f ? b[k] / top : 0.0f;
    const std::vector<float> decoded = round_trip(unit, basis.width, basis.height);
    for (std::size_t k = 0; k < texels; ++k) {
      for (int c = 0; c < 3; ++c) sum[3 * k + static_cast<std::size_t>(c)] += static_cast<double>(w.face[static_cast<std::size_t>(i)][c]) * top * decoded[k];
    }
  }
  std::vector<float> T(3 * texels);
  for (std::size_t k = 0; k < texels; ++k) {
    for (int c = 0; c < 3; ++c) {
      double t = sum[3 * k + static_cast<std::size_t>(c)];
      if (!w.sun.isZero()) t += static_cast<double>(w.sun[c]) * visibility[k];
      T[3 * k + static_cast<std::size_t>(c)] = w.no_light[static_cast<std::size_t>(c)] ? 1.0f : static_cast<float>(std::clamp(t, 0.0, 1.0));
    }
  }
  return T;
}

TEST_F(EacBlend, DriverDecodesOurBlocksAndTheBlendStaysWithinTheMeasuredError) {
  for (const auto& [layers, width, height] : {std::tuple{40, 67, 45}, std::tuple{7, 16, 12}}) {
    const test::RandomScene scene = random_scene(layers, width, height, 11);
    const BlendWeights w = blend_weights(scene.basis, scene.S, scene.sun);
    ASSERT_FALSE(w.sun.isZero());
    std::vector<float> exact(3 * scene.basis.texel_count());
    blend_cpu(scene.basis, w, scene.visibility, exact);
    const std::vector<float> expected = decoded_blend(scene.basis, w, scene.visibility);
    const test::VisibilityTexture sun(width, height, scene.visibility);
    for (const bool packed : {false, true}) {
      SCOPED_TRACE(std::string(packed ? "RG11" : "R11") + ", " + std::to_string(layers) + " layers");
      GpuBlendOptions options = test::blend_options(BasisStorage::Eac11, ShadowRatioFormat::Float);
      options.pack_layers = packed;
      GpuBlender blender(scene.basis, options);
      EXPECT_EQ(blender.slices(), packed ? (layers + 1) / 2 : layers);
      EXPECT_EQ(blender.basis_bytes(), eac_block_count(width, height) * 8 * static_cast<std::size_t>(blender.slices()) *
                                           (packed ? 2u : 1u));
      ASSERT_EQ(blender.eac_error().size(), static_cast<std::size_t>(layers));
      ASSERT_TRUE(blender.blend(w, &sun.texture));
      const std::vector<float> T = blender.read_back();
      ASSERT_EQ(T.size(), exact.size());
      // Against our decoder: the driver decodes the same blocks to the same values (fp32 sums).
      const double decoding = max_error(T, expected);
      // Against the exact blend: within Σ_i |w_i| max_i e_i, e_i the error measured on upload.
      double bound = 0.0;
      for (int c = 0; c < 3; ++c) {
        double channel = 0.0;
        for (const int i : w.active) {
          channel += std::abs(w.face[static_cast<std::size_t>(i)][c]) * blender.eac_error()[static_cast<std::size_t>(i)];
        }
        bound = std::max(bound, channel);
      }
      const double error = max_error(T, exact);
      std::printf("measured: EAC %s, %d random layers: max |T - T_decoded| = %.3g, max |T - T_exact| = %.3g (bound %.3g)\n",
                  packed ? "RG11" : "R11", layers, decoding, error, bound);
      EXPECT_LE(decoding, 2e-5);
      EXPECT_LE(error, bound + 2e-5);
      EXPECT_EQ(std::count_if(T.begin(), T.end(), [](float t) { return !(t >= 0.0f && t <= 1.0f); }), 0);
    }
  }
}

TEST_F(EacBlend, RefusesNegativeLayers) {
  // A PCA basis has eigen-images of either sign; unsigned EAC cannot hold them.
  const BasisImages basis = make_basis(8, 8, {0.5, 0.5}, [](int i, std::size_t t) { return i == 1 && t == 3 ? -0.25f : 0.25f; });
  EXPECT_THROW(GpuBlender(basis, test::blend_options(BasisStorage::Eac11, ShadowRatioFormat::Float)), InputError);
}

}  // namespace
}  // namespace skylit::blend
