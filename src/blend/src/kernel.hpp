#pragma once
// The inner loop of blend_cpu, private to the render module: one thread's range of texels,
// processed in cache-sized blocks. Two variants compute the same sums: a portable one and one
// for CPUs with AVX2, F16C and FMA (chosen at run time).
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

namespace skylit::blend::detail {

// Texels per block: three float accumulators (24 KiB) stay in L1 next to the half strips of the
// layers being summed, and each layer's strip (4 KiB) is read once per block (1024 and 4096
// measured slower).
inline constexpr std::size_t kBlockTexels = 2048;
// Blocks per unit of work handed to a thread (16 Ki texels: 32 units on a 512² plane).
inline constexpr std::size_t kChunkBlocks = 8;

struct BlendJob {
  const std::uint16_t* half = nullptr;   // layer-major basis images
  std::size_t layer_stride = 0;          // texels per layer
  std::span<const int> active;           // layers to sum, ascending
  std::span<const float> weights;        // 3 per active layer: w_r, w_g, w_b
  // Separated terms (the sun, further sources): V_k per texel and w_k (3 per source), added in
  // order after the layers. Empty: no separated term.
  std::span<const float* const> source_visibility;
  std::span<const float> source_weights;
  bool no_light[3] = {false, false, false};
  float* out = nullptr;                  // 3 floats per texel, RGB
};

struct RangeStats {
  float max_t = -std::numeric_limits<float>::infinity();  // before clamping, NaN ignored
  float min_t = std::numeric_limits<float>::infinity();
  std::int64_t clamped = 0;
  bool bad_visibility = false;           // a V outside [0, 1] or NaN
};

// Blends texels [begin, end) of `job` into job.out; per texel the sum runs over the active
// layers in order, so results do not depend on how texels are split into ranges or blocks.
void blend_range_portable(const BlendJob& job, std::size_t begin, std::size_t end, RangeStats& stats);
void blend_range_avx2(const BlendJob& job, std::size_t begin, std::size_t end, RangeStats& stats);
void halves_to_floats_avx2(const std::uint16_t* in, float* out, std::size_t n);

// The cropped form's inner loop (cpu_blend.cpp): r, g, b[x] += Σ_j w_j · (B_j[x] − fill_j) over a
// run of `count` texels of one row that `layers` layers (up to 4 per call in the AVX2 variant,
// which converts with F16C and adds with FMA) all cover; from[j] points at layer j's halves
// for the run, weights holds 3 per layer. Per texel the layers are added in order j = 0, 1, …
void add_spans_portable(const std::uint16_t* const* from, const float* fills, const float* weights, int layers,
                        std::size_t count, float* r, float* g, float* b);
void add_spans_avx2(const std::uint16_t* const* from, const float* fills, const float* weights, int layers,
                    std::size_t count, float* r, float* g, float* b);

bool cpu_has_avx2_f16c_fma();

// Exact half → float (blend::half_to_float), inline for the kernels. Moves exponent and
// mantissa into place and rebiases the exponent (15 → 127); infinities and NaNs get the maximal
// exponent, and zeros and subnormals are normalised by an exact float subtraction:
// 2^-14·(1 + m/1024) − 2^-14 = m·2^-24. Masks instead of branches, so that loops over it
// vectorise with plain SSE2 or NEON.
inline float half_bits_to_float(std::uint16_t h) {
  const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
  const std::uint32_t magnitude = static_cast<std::uint32_t>(h & 0x7fffu) << 13;
  const std::uint32_t exponent = magnitude & 0x0f800000u;
  const std::uint32_t special = 0u - static_cast<std::uint32_t>(exponent == 0x0f800000u);  // inf, NaN: all ones
  const std::uint32_t small = 0u - static_cast<std::uint32_t>(exponent == 0);  // zero, subnormal
  const std::uint32_t bits =
      magnitude + ((127u - 15u) << 23) + (special & ((128u - 16u) << 23)) + (small & (1u << 23));
  const std::uint32_t normalised =
      std::bit_cast<std::uint32_t>(std::bit_cast<float>(bits) - std::bit_cast<float>(113u << 23));
  return std::bit_cast<float>(((small & normalised) | (~small & bits)) | sign);
}

}  // namespace skylit::blend::detail
