// The two blend kernels. Per texel both compute acc = Σ_active w_i·B_i (+ Σ_k w_k·V_k) in float, in
// layer order, then clamp to [0, 1]; they differ only in how (the AVX2 one fuses each multiply
// and add, so the two agree to float rounding, not bit for bit). The AVX2 kernel is bound by its
// three FMAs per texel and layer about as much as by memory (1.2 cycles per 8 texel-layers with
// the layers in L2 on the Zen 5 of RESULTS.md). An AVX-512 variant of its inner loop (16 texels
// per vector, same bits) was twice as fast in L2 but 7% (1 thread) and 13% (2 threads) slower
// from memory on that Zen 5, and no faster from memory on Zen 4, so it was not kept.
#include "kernel.hpp"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#include <immintrin.h>
#define SKYLIT_HAVE_X86 1
#else
#define SKYLIT_HAVE_X86 0
#endif

namespace skylit::blend::detail {
namespace {

// Three channel accumulators for one block.
struct alignas(64) BlockBuffers {
  float acc[3][kBlockTexels];
};

// A channel without light is 1 everywhere: written into its accumulator, so that the clamp and
// the statistics below treat it like any other value (1 is neither clamped nor above one).
inline void fill_no_light(const BlendJob& job, float (*acc)[kBlockTexels], std::size_t count) {
  for (int c = 0; c < 3; ++c) {
    if (job.no_light[c]) std::fill_n(acc[c], count, 1.0f);
  }
}

// Clamps, measures and writes texels [from, to) of a block whose sums are in acc; the scalar
// tail of the AVX2 kernel uses it too, so both treat every value alike.
inline void finish_scalar(const BlendJob& job, float (*acc)[kBlockTexels], std::size_t block_begin,
                          std::size_t from, std::size_t to, RangeStats& stats) {
  float* out = job.out + 3 * block_begin;
  float max_t = stats.max_t;
  float min_t = stats.min_t;
  std::int64_t clamped = 0;
  for (std::size_t k = from; k < to; ++k) {
    for (std::size_t c = 0; c < 3; ++c) {
      const float t = acc[c][k];
      max_t = t > max_t ? t : max_t;  // NaN compares false: ignored
      min_t = t < min_t ? t : min_t;
      clamped += static_cast<std::int64_t>((t > 1.0f) | !(t >= 0.0f));
      out[3 * k + c] = t > 1.0f ? 1.0f : (t >= 0.0f ? t : 0.0f);  // NaN → 0, never NaN out
    }
  }
  stats.max_t = max_t;
  stats.min_t = min_t;
  stats.clamped += clamped;
}

// Adds layers active[a .. a+L) to the accumulators, converting each half as it is read; L layers
// per pass load and store the accumulators once per L layers (plain loops: the compiler
// vectorises them for SSE2 or NEON). Per texel the additions run in layer order.
template <int L>
inline void accumulate_portable(const BlendJob& job, std::size_t a, std::size_t block, std::size_t count,
                                float (*acc)[kBlockTexels]) {
  const std::uint16_t* strip[L];
  float w[L][3];
  for (int j = 0; j < L; ++j) {
    strip[j] = job.half + static_cast<std::size_t>(job.active[a + static_cast<std::size_t>(j)]) * job.layer_stride + block;
    for (int c = 0; c < 3; ++c) w[j][c] = job.weights[3 * (a + static_cast<std::size_t>(j)) + static_cast<std::size_t>(c)];
  }
  float* r = acc[0];
  float* g = acc[1];
  float* b = acc[2];
  for (std::size_t k = 0; k < count; ++k) {
    float x[L];
    for (int j = 0; j < L; ++j) x[j] = half_bits_to_float(strip[j][k]);
    float sr = r[k];
    float sg = g[k];
    float sb = b[k];
    for (int j = 0; j < L; ++j) {
      sr += w[j][0] * x[j];
      sg += w[j][1] * x[j];
      sb += w[j][2] * x[j];
    }
    r[k] = sr;
    g[k] = sg;
    b[k] = sb;
  }
}

}  // namespace

void blend_range_portable(const BlendJob& job, std::size_t begin, std::size_t end, RangeStats& stats) {
  BlockBuffers buffers;
  float (*acc)[kBlockTexels] = buffers.acc;
  const std::size_t active = job.active.size();
  for (std::size_t block = begin; block < end; block += kBlockTexels) {
    const std::size_t count = std::min(kBlockTexels, end - block);
    for (int c = 0; c < 3; ++c) std::fill_n(acc[c], count, 0.0f);
    std::size_t a = 0;
    for (; a + 4 <= active; a += 4) accumulate_portable<4>(job, a, block, count, acc);
    for (; a < active; ++a) accumulate_portable<1>(job, a, block, count, acc);
    for (std::size_t s = 0; s < job.source_visibility.size(); ++s) {
      const float* v = job.source_visibility[s] + block;
      const float* ws = job.source_weights.data() + 3 * s;
      std::uint32_t bad = 0;
      for (std::size_t k = 0; k < count; ++k) {
        bad |= static_cast<std::uint32_t>(!(v[k] >= 0.0f) | !(v[k] <= 1.0f));
        acc[0][k] += ws[0] * v[k];
        acc[1][k] += ws[1] * v[k];
        acc[2][k] += ws[2] * v[k];
      }
      stats.bad_visibility |= bad != 0;
    }
    fill_no_light(job, acc, count);
    finish_scalar(job, acc, block, 0, count, stats);
  }
}

void add_spans_portable(const std::uint16_t* const* from, const float* fills, const float* weights, int layers,
                        std::size_t count, float* __restrict r, float* __restrict g, float* __restrict b) {
  for (std::size_t x = 0; x < count; ++x) {
    float sr = r[x], sg = g[x], sb = b[x];
    for (int j = 0; j < layers; ++j) {
      const float d = half_bits_to_float(from[j][x]) - fills[j];
      sr += weights[3 * j] * d;
      sg += weights[3 * j + 1] * d;
      sb += weights[3 * j + 2] * d;
    }
    r[x] = sr;
    g[x] = sg;
    b[x] = sb;
  }
}

#if SKYLIT_HAVE_X86

bool cpu_has_avx2_f16c_fma() {
  // __builtin_cpu_supports("avx2") also checks that the OS saves the AVX registers; F16C is read
  // from CPUID directly (not every compiler's builtin knows its name). Asked once: CPUID traps to
  // the hypervisor on a virtual machine, and the callers ask per block.
  static const bool available = [] {
    unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
    const bool f16c = __get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && (ecx & bit_F16C) != 0;
    return f16c && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }();
  return available;
}

namespace {

// The strips the kernel reads next (the next group of layers, or the first group of the next
// block), fetched while it sums the current ones: the hardware prefetchers see only short runs
// (one 4 KiB strip per layer, then a jump to another layer), so without this every strip would
// start with a full memory latency (measured: 1.3× the time on a 640-face plane). Every 32 texels
// the kernel fetches the line at the same offset of each next strip, so that the next group
// arrives at the pace it is read. Fetching the next strips one after another instead (all of
// strip 0 in the first quarter of a pass, and so on) left two threads 1.09× slower on 40-face
// planes; fetching two groups ahead, or into L2 only, was no better.
struct NextStrips {
  const std::uint16_t* strip[4] = {nullptr, nullptr, nullptr, nullptr};
};

// Texels k … k+7 of L strips into the accumulators.
template <int L>
__attribute__((target("avx2,f16c,fma"), always_inline)) inline void accumulate_step(
    const std::uint16_t* const (&strip)[L], const __m256 (&w)[L][3], float (*acc)[kBlockTexels], std::size_t k) {
  __m256 x[L];
  for (int j = 0; j < L; ++j) x[j] = _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(strip[j] + k)));
  for (int c = 0; c < 3; ++c) {
    __m256 s = _mm256_load_ps(acc[c] + k);
    for (int j = 0; j < L; ++j) s = _mm256_fmadd_ps(x[j], w[j][c], s);
    _mm256_store_ps(acc[c] + k, s);
  }
}

// Adds the strips of layers active[a .. a+L) to the accumulators, L = 1 … 4 at compile time:
// summing several layers per pass loads and stores the accumulators once per L layers. The
// order of the fused multiply-adds per texel is the layer order whatever L is.
template <int L>
__attribute__((target("avx2,f16c,fma"))) inline void accumulate_layers(const BlendJob& job, std::size_t a,
                                                                       std::size_t block, std::size_t count,
                                                                       float (*acc)[kBlockTexels],
                                                                       const NextStrips& next) {
  const std::uint16_t* strip[L];
  __m256 w[L][3];
  float ws[L][3];
  for (int j = 0; j < L; ++j) {
    strip[j] = job.half + static_cast<std::size_t>(job.active[a + j]) * job.layer_stride + block;
    for (int c = 0; c < 3; ++c) {
      ws[j][c] = job.weights[3 * (a + j) + c];
      w[j][c] = _mm256_set1_ps(ws[j][c]);
    }
  }
  // One 64-byte line (32 halves) of each next strip per 32 texels.
  const std::size_t vectors = count & ~std::size_t{7};
  const std::size_t lines = count & ~std::size_t{31};
  std::size_t k = 0;
  for (; k < lines; k += 32) {
    for (const std::uint16_t* ahead : next.strip) {
      if (ahead) _mm_prefetch(reinterpret_cast<const char*>(ahead + k), _MM_HINT_T0);
    }
    accumulate_step<L>(strip, w, acc, k);
    accumulate_step<L>(strip, w, acc, k + 8);
    accumulate_step<L>(strip, w, acc, k + 16);
    accumulate_step<L>(strip, w, acc, k + 24);
  }
  for (; k < vectors; k += 8) accumulate_step<L>(strip, w, acc, k);
  for (; k < count; ++k) {
    for (int j = 0; j < L; ++j) {
      const float x = half_bits_to_float(strip[j][k]);
      for (int c = 0; c < 3; ++c) acc[c][k] = std::fma(x, ws[j][c], acc[c][k]);
    }
  }
}

// SoA → AoS for 8 texels: r, g, b vectors to 24 interleaved floats.
__attribute__((target("avx2"))) inline void store_rgb(float* out, __m256 r, __m256 g, __m256 b) {
  const __m256 rg = _mm256_shuffle_ps(r, g, _MM_SHUFFLE(2, 0, 2, 0));  // r0 r2 g0 g2 | r4 r6 g4 g6
  const __m256 gb = _mm256_shuffle_ps(g, b, _MM_SHUFFLE(3, 1, 3, 1));  // g1 g3 b1 b3 | …
  const __m256 br = _mm256_shuffle_ps(b, r, _MM_SHUFFLE(3, 1, 2, 0));  // b0 b2 r1 r3 | …
  const __m256 p03 = _mm256_shuffle_ps(rg, br, _MM_SHUFFLE(2, 0, 2, 0));  // r0 g0 b0 r1 | r4 g4 b4 r5
  const __m256 p14 = _mm256_shuffle_ps(gb, rg, _MM_SHUFFLE(3, 1, 2, 0));  // g1 b1 r2 g2 | g5 b5 r6 g6
  const __m256 p25 = _mm256_shuffle_ps(br, gb, _MM_SHUFFLE(3, 1, 3, 1));  // b2 r3 g3 b3 | b6 r7 g7 b7
  const __m256 v0 = _mm256_permute2f128_ps(p03, p14, 0x20);
  const __m256 v1 = _mm256_permute2f128_ps(p25, p03, 0x30);
  const __m256 v2 = _mm256_permute2f128_ps(p14, p25, 0x31);
  _mm256_storeu_ps(out, v0);
  _mm256_storeu_ps(out + 8, v1);
  _mm256_storeu_ps(out + 16, v2);
}

}  // namespace

__attribute__((target("avx2,f16c,fma"))) void blend_range_avx2(const BlendJob& job, std::size_t begin,
                                                               std::size_t end, RangeStats& stats) {
  BlockBuffers buffers;
  float (*acc)[kBlockTexels] = buffers.acc;
  const __m256 zero = _mm256_setzero_ps();
  const __m256 one = _mm256_set1_ps(1.0f);
  __m256 max_t = _mm256_set1_ps(stats.max_t);
  __m256 min_t = _mm256_set1_ps(stats.min_t);
  __m256 bad_v = zero;
  std::int64_t clamped = 0;
  const std::size_t active = job.active.size();
  for (std::size_t block = begin; block < end; block += kBlockTexels) {
    const std::size_t count = std::min(kBlockTexels, end - block);
    const std::size_t vectors = count & ~std::size_t{7};
    for (int c = 0; c < 3; ++c) std::fill_n(acc[c], count, 0.0f);
    // Groups of 4 layers, then single ones; each pass prefetches the next group, after the last
    // one the first group of the next block of the range.
    const auto group_size = [active](std::size_t at) -> std::size_t { return at + 4 <= active ? 4 : 1; };
    const auto next_of = [&](std::size_t at) {
      NextStrips next;
      std::size_t next_block = block;
      std::size_t next_at = at + group_size(at);
      if (next_at >= active) {
        next_block += kBlockTexels;
        next_at = 0;
      }
      if (next_block >= end) return next;
      for (std::size_t j = 0; j < group_size(next_at); ++j) {
        next.strip[j] = job.half + static_cast<std::size_t>(job.active[next_at + j]) * job.layer_stride + next_block;
      }
      return next;
    };
    std::size_t a = 0;
    for (; a + 4 <= active; a += 4) accumulate_layers<4>(job, a, block, count, acc, next_of(a));
    for (; a < active; ++a) accumulate_layers<1>(job, a, block, count, acc, next_of(a));

    for (std::size_t s = 0; s < job.source_visibility.size(); ++s) {
      const float* v = job.source_visibility[s] + block;
      const float* ws = job.source_weights.data() + 3 * s;
      const __m256 sr = _mm256_set1_ps(ws[0]);
      const __m256 sg = _mm256_set1_ps(ws[1]);
      const __m256 sb = _mm256_set1_ps(ws[2]);
      for (std::size_t k = 0; k < vectors; k += 8) {
        const __m256 x = _mm256_loadu_ps(v + k);
        // Outside [0, 1] or NaN (unordered compares are true for NaN).
        bad_v = _mm256_or_ps(bad_v, _mm256_or_ps(_mm256_cmp_ps(x, zero, _CMP_NGE_UQ), _mm256_cmp_ps(x, one, _CMP_NLE_UQ)));
        _mm256_store_ps(acc[0] + k, _mm256_fmadd_ps(x, sr, _mm256_load_ps(acc[0] + k)));
        _mm256_store_ps(acc[1] + k, _mm256_fmadd_ps(x, sg, _mm256_load_ps(acc[1] + k)));
        _mm256_store_ps(acc[2] + k, _mm256_fmadd_ps(x, sb, _mm256_load_ps(acc[2] + k)));
      }
      for (std::size_t k = vectors; k < count; ++k) {
        stats.bad_visibility |= !(v[k] >= 0.0f && v[k] <= 1.0f);
        for (int c = 0; c < 3; ++c) acc[c][k] = std::fma(v[k], ws[c], acc[c][k]);
      }
    }

    fill_no_light(job, acc, count);
    float* out = job.out + 3 * block;
    for (std::size_t k = 0; k < vectors; k += 8) {
      __m256 t[3];
      for (int c = 0; c < 3; ++c) {
        t[c] = _mm256_load_ps(acc[c] + k);
        // max/min return their second operand when one is NaN: NaN never enters the extremes,
        // and the clamp turns NaN into 0.
        max_t = _mm256_max_ps(t[c], max_t);
        min_t = _mm256_min_ps(t[c], min_t);
        const __m256 outside = _mm256_or_ps(_mm256_cmp_ps(t[c], one, _CMP_GT_OQ), _mm256_cmp_ps(t[c], zero, _CMP_NGE_UQ));
        clamped += __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(outside)));
        t[c] = _mm256_min_ps(_mm256_max_ps(t[c], zero), one);
      }
      store_rgb(out + 3 * k, t[0], t[1], t[2]);
    }
    finish_scalar(job, acc, block, vectors, count, stats);
  }
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, max_t);
  stats.max_t = std::max(stats.max_t, *std::max_element(lanes, lanes + 8));
  _mm256_store_ps(lanes, min_t);
  stats.min_t = std::min(stats.min_t, *std::min_element(lanes, lanes + 8));
  stats.clamped += clamped;
  stats.bad_visibility |= _mm256_movemask_ps(bad_v) != 0;
}

__attribute__((target("avx2,f16c"))) void halves_to_floats_avx2(const std::uint16_t* in, float* out,
                                                               std::size_t n) {
  const std::size_t vectors = n & ~std::size_t{7};
  for (std::size_t k = 0; k < vectors; k += 8) {
    _mm256_storeu_ps(out + k, _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + k))));
  }
  for (std::size_t k = vectors; k < n; ++k) out[k] = half_bits_to_float(in[k]);
}

// Up to four layers per pass: the accumulators are loaded and stored once per pass (one layer per
// pass is bound by its three stores per texel).
template <int L>
__attribute__((target("avx2,f16c,fma"))) inline void add_spans_avx2_n(const std::uint16_t* const* from, const float* fills,
                                                                  const float* weights, std::size_t count, float* r,
                                                                  float* g, float* b) {
  __m256 wr[L], wg[L], wb[L], fill[L];
  for (int j = 0; j < L; ++j) {
    wr[j] = _mm256_set1_ps(weights[3 * j]);
    wg[j] = _mm256_set1_ps(weights[3 * j + 1]);
    wb[j] = _mm256_set1_ps(weights[3 * j + 2]);
    fill[j] = _mm256_set1_ps(fills[j]);
  }
  const std::size_t vectors = count & ~std::size_t{7};
  for (std::size_t k = 0; k < vectors; k += 8) {
    __m256 ar = _mm256_loadu_ps(r + k), ag = _mm256_loadu_ps(g + k), ab = _mm256_loadu_ps(b + k);
    for (int j = 0; j < L; ++j) {
      const __m256 d =
          _mm256_sub_ps(_mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(from[j] + k))), fill[j]);
      ar = _mm256_fmadd_ps(wr[j], d, ar);
      ag = _mm256_fmadd_ps(wg[j], d, ag);
      ab = _mm256_fmadd_ps(wb[j], d, ab);
    }
    _mm256_storeu_ps(r + k, ar);
    _mm256_storeu_ps(g + k, ag);
    _mm256_storeu_ps(b + k, ab);
  }
  const std::uint16_t* tail[4];
  for (int j = 0; j < L; ++j) tail[j] = from[j] + vectors;
  add_spans_portable(tail, fills, weights, L, count - vectors, r + vectors, g + vectors, b + vectors);
}

__attribute__((target("avx2,f16c,fma"))) void add_spans_avx2(const std::uint16_t* const* from, const float* fills,
                                                             const float* weights, int layers, std::size_t count,
                                                             float* r, float* g, float* b) {
  switch (layers) {
    case 1: add_spans_avx2_n<1>(from, fills, weights, count, r, g, b); break;
    case 2: add_spans_avx2_n<2>(from, fills, weights, count, r, g, b); break;
    case 3: add_spans_avx2_n<3>(from, fills, weights, count, r, g, b); break;
    case 4: add_spans_avx2_n<4>(from, fills, weights, count, r, g, b); break;
    default: add_spans_portable(from, fills, weights, layers, count, r, g, b); break;
  }
}

#else  // not x86: only the portable kernel exists

void add_spans_avx2(const std::uint16_t* const* from, const float* fills, const float* weights, int layers,
                    std::size_t count, float* r, float* g, float* b) {
  add_spans_portable(from, fills, weights, layers, count, r, g, b);
}

bool cpu_has_avx2_f16c_fma() { return false; }


void blend_range_avx2(const BlendJob& job, std::size_t begin, std::size_t end, RangeStats& stats) {
  blend_range_portable(job, begin, end, stats);
}

void halves_to_floats_avx2(const std::uint16_t* in, float* out, std::size_t n) {
  for (std::size_t k = 0; k < n; ++k) out[k] = half_bits_to_float(in[k]);
}

#endif

}  // namespace skylit::blend::detail
