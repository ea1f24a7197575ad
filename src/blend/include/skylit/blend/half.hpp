#pragma once
// IEEE half floats, the bake's storage of basis images: scalar and bulk (F16C) conversions.
#include <cstdint>
#include <span>

namespace skylit::blend {

float half_to_float(std::uint16_t h);
std::uint16_t float_to_half(float f);   // round to nearest even

// Bulk half_to_float with F16C where the CPU has it: equal to the scalar function for every
// value but signalling NaNs (F16C quiets them). in and out must have the same size.
void halves_to_floats(std::span<const std::uint16_t> in, std::span<float> out);
// Bulk float_to_half (round to nearest even; beyond ±65504: ±infinity). Same sizes.
void floats_to_halves(std::span<const float> in, std::span<std::uint16_t> out);

}  // namespace skylit::blend
