// IEEE 754 binary16 <-> binary32, exact: subnormals, infinities, NaN payloads, round to nearest
// even.
#include <Imath/half.h>
#include <stdexcept>
#include <string>

#include "kernel.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend {

// Imath's (Debian's libimath, OpenEXR's own): the same values bit for bit as skylit's own
// integer conversions it replaced, and six times faster (bench/half_bench.cpp, bench/RESULTS.md).
float half_to_float(std::uint16_t h) { return imath_half_to_float(h); }

std::uint16_t float_to_half(float f) { return imath_float_to_half(f); }

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

void floats_to_halves(std::span<const float> in, std::span<std::uint16_t> out) {
  if (in.size() != out.size()) {
    throw std::invalid_argument("floats_to_halves: " + std::to_string(in.size()) + " floats into " +
                                std::to_string(out.size()) + " halves");
  }
  for (std::size_t i = 0; i < in.size(); ++i) out[i] = float_to_half(in[i]);
}

}  // namespace skylit::blend
