#pragma once
// The light map's two sums per sky (BuildingIrradiance's, per row of layers and per texel) as
// kernels: AVX2 and FMA (F16C for values held in half floats) where the CPU has them, plain loops
// elsewhere; both sum in float, the same up to the order the lanes add in.
#include <cstddef>
#include <cstdint>

namespace skylit::render::light_map_kernels {

// The AVX2/FMA/F16C paths run where blend::blend_simd_available().

// out[3r + c] = Σ_l rows[r · layers + l] · planar[c · layers + l], for r in [0, n) and c in
// {0, 1, 2}: n rows of `layers` values (float or IEEE half bits) times three coefficient columns.
void row_products(const float* rows, std::size_t n, std::size_t layers, const float* planar, float* out);
void row_products(const std::uint16_t* rows, std::size_t n, std::size_t layers, const float* planar, float* out);

// out[c] += chart[c] + Σ_k a[k] · chart[3 + c · K + k] for c in {0, 1, 2}: one texel's K weights
// (float or half bits) against its chart's sums held planar (μ·S per channel, then p_k·S for
// every k, one channel after another).
void texel_sum(const float* a, std::size_t K, const float* chart, float* out);
void texel_sum(const std::uint16_t* a, std::size_t K, const float* chart, float* out);

// The plain loops alone, whatever the CPU has (what the others equal, up to the lanes' order).
namespace portable {
void row_products(const float* rows, std::size_t n, std::size_t layers, const float* planar, float* out);
void row_products(const std::uint16_t* rows, std::size_t n, std::size_t layers, const float* planar, float* out);
void texel_sum(const float* a, std::size_t K, const float* chart, float* out);
void texel_sum(const std::uint16_t* a, std::size_t K, const float* chart, float* out);
}  // namespace portable

}  // namespace skylit::render::light_map_kernels
