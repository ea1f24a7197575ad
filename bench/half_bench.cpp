// Half-float conversions: skylit's own (blend/half.hpp, the bake's storage) against Imath's
// (Debian's libimath, which OpenEXR uses), to say where Imath's would do as well. Scalar both
// ways over every one of the 65 536 halves and over a plane's worth of floats; the bulk F16C path
// (halves_to_floats) beside them.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include <Imath/half.h>

#include "skylit/blend/half.hpp"

namespace {

std::vector<std::uint16_t> every_half() {
  std::vector<std::uint16_t> h(65536);
  for (std::size_t i = 0; i < h.size(); ++i) h[i] = static_cast<std::uint16_t>(i);
  return h;
}

// Visible fractions and steradians as a bake holds them: [0, 0.1], a few exact zeros and ones.
std::vector<float> basis_like_floats(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 0.1f);
  std::vector<float> f(n);
  for (float& x : f) x = u(rng);
  for (std::size_t i = 0; i < n; i += 17) f[i] = 0.0f;
  return f;
}

void HalfToFloat_Skylit(benchmark::State& state) {
  const auto h = every_half();
  for (auto _ : state) {
    float sum = 0;
    for (const std::uint16_t v : h) sum += skylit::blend::half_to_float(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(h.size()));
}
BENCHMARK(HalfToFloat_Skylit);

void HalfToFloat_Imath(benchmark::State& state) {
  const auto h = every_half();
  for (auto _ : state) {
    float sum = 0;
    for (const std::uint16_t v : h) sum += imath_half_to_float(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(h.size()));
}
BENCHMARK(HalfToFloat_Imath);

void HalvesToFloats_SkylitBulk(benchmark::State& state) {
  const auto h = every_half();
  std::vector<float> out(h.size());
  for (auto _ : state) {
    skylit::blend::halves_to_floats(h, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(h.size()));
}
BENCHMARK(HalvesToFloats_SkylitBulk);

void FloatToHalf_Skylit(benchmark::State& state) {
  const auto f = basis_like_floats(1 << 18);
  for (auto _ : state) {
    std::uint32_t sum = 0;
    for (const float v : f) sum += skylit::blend::float_to_half(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(f.size()));
}
BENCHMARK(FloatToHalf_Skylit);

void FloatToHalf_Imath(benchmark::State& state) {
  const auto f = basis_like_floats(1 << 18);
  for (auto _ : state) {
    std::uint32_t sum = 0;
    for (const float v : f) sum += imath_float_to_half(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(f.size()));
}
BENCHMARK(FloatToHalf_Imath);

// Whether the two agree, as a counter (0 = every half and every float above converts the same).
void Disagreements(benchmark::State& state) {
  const auto h = every_half();
  const auto f = basis_like_floats(1 << 18);
  std::int64_t differ = 0;
  for (auto _ : state) {
    differ = 0;
    for (const std::uint16_t v : h) {
      const float a = skylit::blend::half_to_float(v), b = imath_half_to_float(v);
      differ += (a != b && !(a != a && b != b)) ? 1 : 0;  // NaNs compare unequal to themselves
    }
    for (const float v : f) differ += skylit::blend::float_to_half(v) != imath_float_to_half(v) ? 1 : 0;
  }
  state.counters["disagreements"] = static_cast<double>(differ);
}
BENCHMARK(Disagreements)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
