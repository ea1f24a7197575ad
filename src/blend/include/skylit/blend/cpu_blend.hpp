#pragma once
// Shadow ratios on the CPU: the reference that every GPU blend is tested against, and the
// fallback for machines without a GPU (paper 003, section 3.3, plus an exact sun term).
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/blend/basis.hpp"

namespace skylit::blend {


class BlendWorkers;

// The shadow ratio of texel x of plane j:
//
//   T_j(x) = (Σ_i S_i B_{j,i}(x) + E_sun V(x, ω_sun) c) / (Σ_i S_i A_{j,i} + E_sun c),
//   c = max(0, n·ω_sun),  per colour channel.
struct SunLight {
  Vec3 direction = Vec3::UnitZ();                    // unit, site frame, towards the sun
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();  // E_sun, RGB: irradiance facing the sun
};

struct BlendOptions {
  // A channel whose denominator Σ S_i A_i + E_sun c is at or under this is "no light": T = 1.
  double min_denominator = 1e-12;
  int threads = 0;                     // 0 = all hardware threads
  // Threads kept between calls (workers.hpp); when set, `threads` is ignored. Without it
  // each call starts and joins its own threads.
  BlendWorkers* workers = nullptr;
  // false: the portable kernel even on a CPU with AVX2/F16C/FMA (tests compare both; benchmarks
  // time both). The two agree within float rounding; each is bit-identical for any `threads`.
  bool use_simd = true;
};

// The weights w_i = S_i / D and w_sun = E_sun c / D (D the denominator) are computed once per
// sky (blend_weights); the blend is then one weighted sum over the plane's basis layers, read
// once each from half floats and accumulated in float. T is always finite and in [0, 1]: when a
// channel's denominator is too small to mean anything (a night sky, a plane that faces away from
// every lit face) that channel is 1 and flagged, and values a hair outside [0, 1] from half-float
// rounding of B ≤ A are clamped and measured.
struct BlendWeights {
  // w_i per stored layer (RGB); zero for skipped faces. For a PCA basis these are the weights of
  // its mean and eigen-images (either sign). A tiled basis (BasisImages::tile) has a set per
  // tile: face[t · layers + k] weighs stored layer k within tile t (tile_count() · layers in all).
  std::vector<Eigen::Vector3f> face;
  std::vector<int> active;             // indices into `face` with a non-zero weight, ascending
  Eigen::Vector3f sun = Eigen::Vector3f::Zero();   // w_sun (RGB), zero without a sun term
  // w_k (RGB) of every separated source, in the order given (sources[0] == sun); one entry or
  // none from blend_weights. blend_cpu reads `sun` only (and refuses more than one source here);
  // blend_cpu_sources reads this (or `sun` when it is empty).
  std::vector<Eigen::Vector3f> sources;
  Eigen::Vector3d denominator = Eigen::Vector3d::Zero();
  std::array<bool, 3> no_light{false, false, false};  // per channel: T = 1
};

// S: one RGB value per source layer (faces without light may be zero). InputError when S has the
// wrong size or holds a non-finite value, or a negative one in a faces basis (corner
// coefficients may be negative: T stays in [0, 1] by the clamp, and a channel whose
// denominator is not above min_denominator is no light).
BlendWeights blend_weights(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                           const std::optional<SunLight>& sun, const BlendOptions& options = {});

// With several separated sources (the sun and compact lamps, sky/sky_estimate.hpp max_sources)
// the sun term becomes Σ_k E_k c_k V_k in the numerator and Σ_k E_k c_k in the denominator
// (blend_weights_sources, blend_cpu_sources, blend_reference_sources); one source gives the
// same T as the single-sun functions, bit for bit. The GPU blend (gpu_blend.hpp) and the live
// service take one separated term: the first source.
//
// The same for several separated sources: w_k = E_k max(0, n·ω_k) / D for each, D including
// every source. InputError as blend_weights, naming the source ("sources[k].energy").
BlendWeights blend_weights_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                                   std::span<const SunLight> sources, const BlendOptions& options = {});

struct BlendStats {
  float max_above_one = 0;             // largest T - 1 before clamping (0 when none)
  float max_below_zero = 0;            // largest -T before clamping (0 when none)
  std::int64_t clamped = 0;            // values clamped
};

// out: width × height × 3 floats, RGB interleaved, row-major texels (the plane's convention).
// sun_visibility: V per texel in [0, 1] (empty: no sun term, or the sun is fully visible when
// weights.sun is non-zero and visibility is empty -> InputError).
BlendStats blend_cpu(const BasisImages& basis, const BlendWeights& weights,
                     std::span<const float> sun_visibility, std::span<float> out,
                     const BlendOptions& options = {});

// The separated terms a blend sums, in source order: weights.sources, or the sun alone when
// that is empty and weights.sun is not zero (weights made by blend_weights for one sun). Inline:
// the GPU blend uses it and builds without this library (bench/gpu_standalone.sh).
inline std::vector<Eigen::Vector3f> separated_terms(const BlendWeights& weights) {
  std::vector<Eigen::Vector3f> terms = weights.sources;
  if (terms.empty() && !weights.sun.isZero(0)) terms.push_back(weights.sun);
  return terms;
}

// Several separated sources: source_visibility[k] is V_k per texel in [0, 1] for weights.sources[k]
// (an empty span is allowed for a source of zero weight). InputError when the count differs from
// weights.sources (or from one, when only weights.sun is set), or a V is missing or out of range.
BlendStats blend_cpu_sources(const BasisImages& basis, const BlendWeights& weights,
                             std::span<const std::span<const float>> source_visibility, std::span<float> out,
                             const BlendOptions& options = {});

// The same in double precision, one thread, no shortcuts: the reference the fast path is
// tested against.
void blend_reference(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                     const std::optional<SunLight>& sun, std::span<const float> sun_visibility,
                     std::span<double> out, const BlendOptions& options = {});

void blend_reference_sources(const BasisImages& basis, std::span<const Eigen::Vector3d> S,
                             std::span<const SunLight> sources,
                             std::span<const std::span<const float>> source_visibility, std::span<double> out,
                             const BlendOptions& options = {});

// True when this CPU has AVX2, F16C and FMA (asked once): blend_cpu with use_simd then runs its
// SIMD kernel, and so do the building's sums (render/light_map_kernels.hpp).
bool blend_simd_available();

}  // namespace skylit::blend
