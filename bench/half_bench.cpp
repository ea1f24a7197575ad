// Half-float conversions (blend/half.hpp, the bake's storage): the scalar ones, which are
// Imath's, both ways over every one of the 65 536 halves and over a plane's worth of floats,
// and the bulk F16C path (halves_to_floats) beside them. bench/RESULTS.md ("Half floats") has
// the figures of skylit's own integer conversions that Imath's replaced.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "skylit/blend/half.hpp"

namespace {

std::vector<std::uint16_t> every_half() {
  std::vector<std::uint16_t> h(65536);
  for (std::size_t i = 0; i < h.size(); ++i) h[i] = static_cast<std::uint16_t>(i);
  return h;
}

// Steradians as a bake holds them: [0, 0.1], with a few exact zeros.
std::vector<float> basis_like_floats(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 0.1f);
  std::vector<float> f(n);
  for (float& x : f) x = u(rng);
  for (std::size_t i = 0; i < n; i += 17) f[i] = 0.0f;
  return f;
}

void HalfToFloat(benchmark::State& state) {
  const auto h = every_half();
  for (auto _ : state) {
    float sum = 0;
    for (const std::uint16_t v : h) sum += skylit::blend::half_to_float(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(h.size()));
}
BENCHMARK(HalfToFloat);

void HalvesToFloats_Bulk(benchmark::State& state) {
  const auto h = every_half();
  std::vector<float> out(h.size());
  for (auto _ : state) {
    skylit::blend::halves_to_floats(h, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(h.size()));
}
BENCHMARK(HalvesToFloats_Bulk);

void FloatToHalf(benchmark::State& state) {
  const auto f = basis_like_floats(1 << 18);
  for (auto _ : state) {
    std::uint32_t sum = 0;
    for (const float v : f) sum += skylit::blend::float_to_half(v);
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(f.size()));
}
BENCHMARK(FloatToHalf);


}  // namespace

BENCHMARK_MAIN();
