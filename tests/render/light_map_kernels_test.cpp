// The light map's sum kernels (render/light_map_kernels.hpp): what this CPU runs equals the plain
// loops, for values in float and in half floats, with row lengths and component counts that are
// and are not a multiple of the eight lanes.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/blend/half.hpp"
#include "skylit/render/light_map_kernels.hpp"

namespace skylit::light_map_kernels_test {
namespace {

namespace kernels = render::light_map_kernels;

std::vector<float> random_values(std::size_t n, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> value(-1.0f, 1.0f);
  std::vector<float> out(n);
  for (float& v : out) v = value(random);
  return out;
}

std::vector<std::uint16_t> halves(const std::vector<float>& values) {
  std::vector<std::uint16_t> out(values.size());
  blend::floats_to_halves(values, out);
  return out;
}

// |a − b| ≤ 1e-5 · Σ|terms| for each: the lanes only reorder the sum.
void expect_near(const std::vector<float>& a, const std::vector<float>& b, const std::vector<float>& scale) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-5 * scale[k] + 1e-30) << "at " << k;
}

TEST(LightMapKernels, RowProductsEqualThePlainLoopsInFloatAndInHalf) {
  for (const std::size_t layers : {1u, 7u, 8u, 480u, 963u}) {
    SCOPED_TRACE(layers);
    constexpr std::size_t rows = 37;
    const std::vector<float> values = random_values(rows * layers, 1), planar = random_values(3 * layers, 2);
    const std::vector<std::uint16_t> held = halves(values);
    std::vector<float> scale(3 * rows, 0.0f);
    for (std::size_t r = 0; r < rows; ++r) {
      for (std::size_t c = 0; c < 3; ++c) {
        for (std::size_t l = 0; l < layers; ++l) scale[3 * r + c] += std::abs(values[r * layers + l] * planar[c * layers + l]);
      }
    }
    std::vector<float> best(3 * rows), plain(3 * rows);
    kernels::row_products(values.data(), rows, layers, planar.data(), best.data());
    kernels::portable::row_products(values.data(), rows, layers, planar.data(), plain.data());
    expect_near(best, plain, scale);
    // Against a double sum too: the plain loop is a float sum of every term.
    for (std::size_t c = 0; c < 3; ++c) {
      double exact = 0.0;
      for (std::size_t l = 0; l < layers; ++l) exact += static_cast<double>(values[l]) * planar[c * layers + l];
      EXPECT_NEAR(plain[c], exact, 1e-5 * scale[c] + 1e-30);
    }
    kernels::row_products(held.data(), rows, layers, planar.data(), best.data());
    kernels::portable::row_products(held.data(), rows, layers, planar.data(), plain.data());
    expect_near(best, plain, scale);
  }
}

TEST(LightMapKernels, TexelSumsEqualThePlainLoopsInFloatAndInHalfAndAddToWhatIsThere) {
  for (const std::size_t K : {1u, 5u, 8u, 32u, 64u, 67u}) {
    SCOPED_TRACE(K);
    const std::vector<float> a = random_values(K, 3), chart = random_values(3 + 3 * K, 4);
    std::vector<float> scale(3, 0.0f);
    for (std::size_t c = 0; c < 3; ++c) {
      scale[c] = 1.0f + std::abs(chart[c]);
      for (std::size_t k = 0; k < K; ++k) scale[c] += std::abs(a[k] * chart[3 + c * K + k]);
    }
    std::vector<float> best{1.0f, 2.0f, 3.0f}, plain{1.0f, 2.0f, 3.0f};
    kernels::texel_sum(a.data(), K, chart.data(), best.data());
    kernels::portable::texel_sum(a.data(), K, chart.data(), plain.data());
    expect_near(best, plain, scale);
    double exact = 1.0 + chart[0];
    for (std::size_t k = 0; k < K; ++k) exact += static_cast<double>(a[k]) * chart[3 + k];
    EXPECT_NEAR(plain[0], exact, 1e-5 * scale[0]);
    const std::vector<std::uint16_t> held = halves(a);
    best = plain = {0.0f, 0.0f, 0.0f};
    kernels::texel_sum(held.data(), K, chart.data(), best.data());
    kernels::portable::texel_sum(held.data(), K, chart.data(), plain.data());
    expect_near(best, plain, scale);
  }
}

}  // namespace
}  // namespace skylit::light_map_kernels_test
