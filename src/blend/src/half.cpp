// IEEE 754 binary16 <-> binary32, exact: subnormals, infinities, NaN payloads, round to nearest
// even. Written out in integer arithmetic so that it is the same on every CPU and compiler.
#include <bit>
#include <stdexcept>
#include <string>

#include "kernel.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {

float half_to_float(std::uint16_t h) { return detail::half_bits_to_float(h); }

std::uint16_t float_to_half(float f) {
  const std::uint32_t x = std::bit_cast<std::uint32_t>(f);
  const auto sign = static_cast<std::uint16_t>((x >> 16) & 0x8000u);
  const std::uint32_t magnitude = x & 0x7fffffffu;
  if (magnitude >= 0x7f800000u) {
    if (magnitude == 0x7f800000u) return static_cast<std::uint16_t>(sign | 0x7c00u);
    // NaN: keep the top payload bits; a payload that would vanish becomes a quiet NaN.
    std::uint32_t payload = (magnitude >> 13) & 0x3ffu;
    if (payload == 0) payload = 0x200u;
    return static_cast<std::uint16_t>(sign | 0x7c00u | payload);
  }
  // 65520 = 65504 + half an ulp rounds (to even) up to infinity.
  if (magnitude >= 0x477ff000u) return static_cast<std::uint16_t>(sign | 0x7c00u);
  if (magnitude >= 0x38800000u) {
    // Normal half: rebias the exponent (127 → 15), drop 13 mantissa bits rounding to even;
    // a carry out of the mantissa correctly bumps the exponent.
    const std::uint32_t rebased = magnitude - ((127u - 15u) << 23);
    std::uint32_t h = rebased >> 13;
    const std::uint32_t rest = rebased & 0x1fffu;
    if (rest > 0x1000u || (rest == 0x1000u && (h & 1u))) ++h;
    return static_cast<std::uint16_t>(sign | h);
  }
  // Subnormal half (or zero): value / 2^-24 rounded to even.
  const std::uint32_t exponent = magnitude >> 23;
  if (exponent < 102) return sign;  // below 2^-25: rounds to zero (2^-25 itself is a tie → 0)
  const std::uint32_t significand = (magnitude & 0x7fffffu) | 0x800000u;
  const std::uint32_t shift = 126u - exponent;  // 14 … 24
  std::uint32_t h = significand >> shift;
  const std::uint32_t rest = significand & ((1u << shift) - 1u);
  const std::uint32_t halfway = 1u << (shift - 1u);
  if (rest > halfway || (rest == halfway && (h & 1u))) ++h;
  return static_cast<std::uint16_t>(sign | h);
}

void halves_to_floats(std::span<const std::uint16_t> in, std::span<float> out) {
  if (in.size() != out.size()) {
    throw std::invalid_argument("halves_to_floats: " + std::to_string(in.size()) + " halves into " +
                                std::to_string(out.size()) + " floats");
  }
  if (detail::cpu_has_avx2_f16c_fma()) {
    detail::halves_to_floats_avx2(in.data(), out.data(), in.size());
    return;
  }
  for (std::size_t i = 0; i < in.size(); ++i) out[i] = detail::half_bits_to_float(in[i]);
}

}  // namespace skylit::blend
