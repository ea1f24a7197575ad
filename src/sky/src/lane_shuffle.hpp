#pragma once
// Permutations of a GCC vector by a constant mask vector: GCC's __builtin_shuffle, and the same
// permutation lane by lane for clang (the fuzz build), which has no such builtin.
#if defined(__clang__)
namespace skylit::sky::lanes {

template <typename Float, typename Mask>
[[gnu::always_inline]] inline Float shuffle(Float a, Float b, Mask mask) {
  constexpr int kWidth = static_cast<int>(sizeof(Float) / sizeof(a[0]));
  Float out;
  for (int lane = 0; lane < kWidth; ++lane) {
    const int from = static_cast<int>(mask[lane]);
    out[lane] = from < kWidth ? a[from] : b[from - kWidth];
  }
  return out;
}

template <typename Float, typename Mask>
[[gnu::always_inline]] inline Float shuffle(Float a, Mask mask) {
  constexpr int kWidth = static_cast<int>(sizeof(Float) / sizeof(a[0]));
  Float out;
  for (int lane = 0; lane < kWidth; ++lane) out[lane] = a[static_cast<int>(mask[lane])];
  return out;
}

}  // namespace skylit::sky::lanes
// A macro, not a function, for GCC: a function taking 32-byte vectors by value changes the ABI
// without AVX (-Wpsabi), even inlined.
#define SKYLIT_SHUFFLE(...) ::skylit::sky::lanes::shuffle(__VA_ARGS__)
#else
#define SKYLIT_SHUFFLE(...) __builtin_shuffle(__VA_ARGS__)
#endif
