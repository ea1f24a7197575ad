// IEEE binary16 conversions: exhaustive over every half, known values, and round-to-nearest-even
// checked against the definition (and against the CPU's F16C instruction where there is one).
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {
namespace {

bool is_nan_half(std::uint16_t h) { return (h & 0x7c00u) == 0x7c00u && (h & 0x3ffu) != 0; }

// The value of a half from its definition, in double.
double half_value(std::uint16_t h) {
  const int sign = (h & 0x8000u) ? -1 : 1;
  const int exponent = (h >> 10) & 0x1f;
  const int mantissa = h & 0x3ff;
  if (exponent == 31) return mantissa ? std::numeric_limits<double>::quiet_NaN() : sign * HUGE_VAL;
  if (exponent == 0) return sign * std::ldexp(mantissa, -24);
  return sign * std::ldexp(1024 + mantissa, exponent - 25);
}

TEST(Half, DecodesEveryHalfExactly) {
  for (std::uint32_t h = 0; h <= 0xffffu; ++h) {
    const auto bits = static_cast<std::uint16_t>(h);
    const float f = half_to_float(bits);
    if (is_nan_half(bits)) {
      ASSERT_TRUE(std::isnan(f)) << std::hex << h;
      ASSERT_EQ(std::signbit(f), (h & 0x8000u) != 0) << std::hex << h;
    } else {
      ASSERT_EQ(static_cast<double>(f), half_value(bits)) << std::hex << h;
      ASSERT_EQ(std::signbit(f), (h & 0x8000u) != 0) << std::hex << h;  // -0 stays -0
    }
  }
}

TEST(Half, EveryHalfRoundTripsBitForBit) {
  // NaN payloads included: float_to_half keeps the payload bits that half_to_float moved up.
  for (std::uint32_t h = 0; h <= 0xffffu; ++h) {
    const auto bits = static_cast<std::uint16_t>(h);
    ASSERT_EQ(float_to_half(half_to_float(bits)), bits) << std::hex << h;
  }
}

TEST(Half, KnownValues) {
  EXPECT_EQ(float_to_half(0.0f), 0x0000);
  EXPECT_EQ(float_to_half(-0.0f), 0x8000);
  EXPECT_EQ(float_to_half(1.0f), 0x3c00);
  EXPECT_EQ(float_to_half(-2.0f), 0xc000);
  EXPECT_EQ(float_to_half(0.5f), 0x3800);
  EXPECT_EQ(float_to_half(1.0f / 3.0f), 0x3555);
  EXPECT_EQ(float_to_half(std::numbers::pi_v<float>), 0x4248);
  EXPECT_EQ(float_to_half(65504.0f), 0x7bff);          // largest half
  EXPECT_EQ(float_to_half(65519.996f), 0x7bff);        // just under the tie
  EXPECT_EQ(float_to_half(65520.0f), 0x7c00);          // tie with odd 65504: rounds up to inf
  EXPECT_EQ(float_to_half(1e10f), 0x7c00);
  EXPECT_EQ(float_to_half(-1e10f), 0xfc00);
  EXPECT_EQ(float_to_half(std::numeric_limits<float>::infinity()), 0x7c00);
  EXPECT_EQ(float_to_half(-std::numeric_limits<float>::infinity()), 0xfc00);
  EXPECT_TRUE(is_nan_half(float_to_half(std::numeric_limits<float>::quiet_NaN())));
  // A NaN whose payload lives only in the low 13 bits must not become infinity.
  EXPECT_TRUE(is_nan_half(float_to_half(std::bit_cast<float>(0x7f800001u))));
  EXPECT_EQ(float_to_half(0x1p-14f), 0x0400);          // smallest normal
  EXPECT_EQ(float_to_half(0x1p-24f), 0x0001);          // smallest subnormal
  EXPECT_EQ(float_to_half(0x1p-25f), 0x0000);          // tie with 0: even
  EXPECT_EQ(float_to_half(0x1.8p-25f), 0x0001);        // above the tie
  EXPECT_EQ(float_to_half(0x1.8p-24f), 0x0002);        // 1.5 ulp: tie, to even 2
  EXPECT_EQ(float_to_half(0x1.4p-24f), 0x0001);
  EXPECT_EQ(float_to_half(0x1.ff8p-15f), 0x03ff);      // largest subnormal, 1023·2^-24
  EXPECT_EQ(float_to_half(0x1.ffap-15f), 0x03ff);
  EXPECT_EQ(float_to_half(0x1.ffcp-15f), 0x0400);      // tie with odd 1023: up into the normals
  EXPECT_EQ(float_to_half(1e-10f), 0x0000);
  EXPECT_EQ(float_to_half(std::numeric_limits<float>::denorm_min()), 0x0000);
  EXPECT_EQ(float_to_half(1.0f + 0x1p-11f), 0x3c00);   // tie: to even
  EXPECT_EQ(float_to_half(1.0f + 0x3p-11f), 0x3c02);   // tie: to even (up)
  EXPECT_EQ(float_to_half(1.0f + 0x1p-11f + 0x1p-20f), 0x3c01);
  EXPECT_EQ(float_to_half(2047.5f), 0x6800);           // 2048 after rounding the carry
}

// Nearest half by definition, ties to even, for finite f below 65520 in magnitude.
TEST(Half, RoundsToNearestEvenBySampling) {
  std::uint64_t checked = 0;
  for (std::uint32_t x = 0; x < 0x477ff000u; x += 397) {  // positive floats up to the overflow tie
    const float f = std::bit_cast<float>(x);
    const std::uint16_t h = float_to_half(f);
    ASSERT_EQ(float_to_half(-f), h | 0x8000u) << f;
    ASSERT_LE(h, 0x7bffu) << f;
    const double error = std::abs(static_cast<double>(f) - half_value(h));
    if (h > 0) {
      const double below = std::abs(static_cast<double>(f) - half_value(static_cast<std::uint16_t>(h - 1)));
      ASSERT_TRUE(error < below || (error == below && (h & 1u) == 0)) << std::hexfloat << f;
    }
    if (h < 0x7bffu) {
      const double above = std::abs(static_cast<double>(f) - half_value(static_cast<std::uint16_t>(h + 1)));
      ASSERT_TRUE(error < above || (error == above && (h & 1u) == 0)) << std::hexfloat << f;
    }
    ++checked;
  }
  EXPECT_GT(checked, 2'000'000u);
}

#if defined(__x86_64__) || defined(__i386__)
__attribute__((target("f16c"))) std::uint16_t hardware_float_to_half(float f) {
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_cvtps_ph(_mm_set_ss(f), _MM_FROUND_TO_NEAREST_INT)));
}

TEST(Half, AgreesWithF16cOnEveryFiniteFloatSampled) {
  if (!blend_simd_available()) GTEST_SKIP() << "this CPU has no F16C (with AVX2 and FMA)";
  for (std::uint64_t x = 0; x <= 0xffffffffu; x += 251) {
    const float f = std::bit_cast<float>(static_cast<std::uint32_t>(x));
    if (std::isnan(f)) continue;  // F16C quiets NaNs; payload handling is ours (tested above)
    ASSERT_EQ(float_to_half(f), hardware_float_to_half(f)) << std::hexfloat << f;
  }
}
#endif

TEST(Half, BulkConversionEqualsScalarForEveryHalf) {
  std::vector<std::uint16_t> in(0x10000 + 5);  // not a multiple of 8: the tail too
  for (std::size_t i = 0; i < in.size(); ++i) in[i] = static_cast<std::uint16_t>(i);
  std::vector<float> out(in.size());
  halves_to_floats(in, out);
  for (std::size_t i = 0; i < in.size(); ++i) {
    const float scalar = half_to_float(in[i]);
    if (is_nan_half(in[i])) {
      ASSERT_TRUE(std::isnan(out[i])) << i;
    } else {
      ASSERT_EQ(std::bit_cast<std::uint32_t>(out[i]), std::bit_cast<std::uint32_t>(scalar)) << i;
    }
  }
  std::vector<float> short_out(3);
  EXPECT_THROW(halves_to_floats(in, short_out), std::invalid_argument);
}

}  // namespace
}  // namespace skylit::blend
