// The light map's sums per sky (light_map_kernels.hpp). The portable loops keep one accumulator
// per channel (the compiler may not reorder a float sum); the AVX2 ones eight lanes per channel,
// added across at the end.
#include "skylit/render/light_map_kernels.hpp"

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#define SKYLIT_LIGHT_MAP_X86 1
#else
#define SKYLIT_LIGHT_MAP_X86 0
#endif

namespace skylit::render::light_map_kernels {
namespace {

inline float value_of(float v) { return v; }
inline float value_of(std::uint16_t h) { return blend::half_to_float(h); }

// e[c] += Σ_{i in [from, n)} v[i] · planar[c · n + i]: a row's layers against the sky's three
// columns, or a texel's weights against its chart's sums; from past the last whole eight lanes.
template <typename Value>
void add_products(const Value* v, std::size_t from, std::size_t n, const float* planar, float* e) {
  for (std::size_t i = from; i < n; ++i) {
    const float x = value_of(v[i]);
    e[0] += x * planar[i];
    e[1] += x * planar[n + i];
    e[2] += x * planar[2 * n + i];
  }
}

template <typename Value>
void row_products_portable(const Value* rows, std::size_t n, std::size_t layers, const float* planar, float* out) {
  for (std::size_t r = 0; r < n; ++r) {
    float* e = out + 3 * r;
    e[0] = e[1] = e[2] = 0.0f;
    add_products(rows + r * layers, 0, layers, planar, e);
  }
}

template <typename Value>
void texel_sum_portable(const Value* a, std::size_t K, const float* chart, float* out) {
  float e[3] = {0.0f, 0.0f, 0.0f};
  add_products(a, 0, K, chart + 3, e);
  for (int c = 0; c < 3; ++c) out[c] += chart[c] + e[c];
}

#if SKYLIT_LIGHT_MAP_X86

__attribute__((target("avx2,fma,f16c"))) inline __m256 load8(const float* v) { return _mm256_loadu_ps(v); }
__attribute__((target("avx2,fma,f16c"))) inline __m256 load8(const std::uint16_t* v) {
  return _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(v)));
}

__attribute__((target("avx2,fma"))) inline float add_across(__m256 v) {
  const __m128 four = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  const __m128 two = _mm_add_ps(four, _mm_movehl_ps(four, four));
  return _mm_cvtss_f32(_mm_add_ss(two, _mm_shuffle_ps(two, two, 1)));
}

// e[c] = Σ_i v[i] · planar[c · n + i], eight lanes per channel.
template <typename Value>
__attribute__((target("avx2,fma,f16c"))) inline void products_avx2(const Value* v, std::size_t n, const float* planar, float* e) {
  const std::size_t vectors = n & ~std::size_t{7};
  __m256 s0 = _mm256_setzero_ps(), s1 = _mm256_setzero_ps(), s2 = _mm256_setzero_ps();
  for (std::size_t i = 0; i < vectors; i += 8) {
    const __m256 x = load8(v + i);
    s0 = _mm256_fmadd_ps(x, _mm256_loadu_ps(planar + i), s0);
    s1 = _mm256_fmadd_ps(x, _mm256_loadu_ps(planar + n + i), s1);
    s2 = _mm256_fmadd_ps(x, _mm256_loadu_ps(planar + 2 * n + i), s2);
  }
  e[0] = add_across(s0);
  e[1] = add_across(s1);
  e[2] = add_across(s2);
  add_products(v, vectors, n, planar, e);
}

template <typename Value>
__attribute__((target("avx2,fma,f16c"))) void row_products_avx2(const Value* rows, std::size_t n, std::size_t layers,
                                                                const float* planar, float* out) {
  for (std::size_t r = 0; r < n; ++r) products_avx2(rows + r * layers, layers, planar, out + 3 * r);
}

template <typename Value>
__attribute__((target("avx2,fma,f16c"))) void texel_sum_avx2(const Value* a, std::size_t K, const float* chart, float* out) {
  float e[3];
  products_avx2(a, K, chart + 3, e);
  for (int c = 0; c < 3; ++c) out[c] += chart[c] + e[c];
}

#endif

}  // namespace

#if SKYLIT_LIGHT_MAP_X86
#define SKYLIT_LIGHT_MAP_DISPATCH(simd, portable) \
  if (blend::blend_simd_available()) {            \
    simd;                                         \
  } else {                                        \
    portable;                                     \
  }
#else
#define SKYLIT_LIGHT_MAP_DISPATCH(simd, portable) portable;
#endif

void row_products(const float* rows, std::size_t n, std::size_t layers, const float* planar, float* out) {
  SKYLIT_LIGHT_MAP_DISPATCH(row_products_avx2(rows, n, layers, planar, out), row_products_portable(rows, n, layers, planar, out))
}
void row_products(const std::uint16_t* rows, std::size_t n, std::size_t layers, const float* planar, float* out) {
  SKYLIT_LIGHT_MAP_DISPATCH(row_products_avx2(rows, n, layers, planar, out), row_products_portable(rows, n, layers, planar, out))
}
void texel_sum(const float* a, std::size_t K, const float* chart, float* out) {
  SKYLIT_LIGHT_MAP_DISPATCH(texel_sum_avx2(a, K, chart, out), texel_sum_portable(a, K, chart, out))
}
void texel_sum(const std::uint16_t* a, std::size_t K, const float* chart, float* out) {
  SKYLIT_LIGHT_MAP_DISPATCH(texel_sum_avx2(a, K, chart, out), texel_sum_portable(a, K, chart, out))
}

#undef SKYLIT_LIGHT_MAP_DISPATCH

namespace portable {
void row_products(const float* rows, std::size_t n, std::size_t layers, const float* planar, float* out) {
  row_products_portable(rows, n, layers, planar, out);
}
void row_products(const std::uint16_t* rows, std::size_t n, std::size_t layers, const float* planar, float* out) {
  row_products_portable(rows, n, layers, planar, out);
}
void texel_sum(const float* a, std::size_t K, const float* chart, float* out) { texel_sum_portable(a, K, chart, out); }
void texel_sum(const std::uint16_t* a, std::size_t K, const float* chart, float* out) { texel_sum_portable(a, K, chart, out); }
}  // namespace portable

}  // namespace skylit::render::light_map_kernels
