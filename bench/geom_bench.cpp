// Dome lookups: face_of per direction (it builds per-pixel tables) and dome construction.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "skylit/geom/dome.hpp"

namespace {

using skylit::geom::Dome;
using skylit::geom::Vec3;

// Uniform directions over the upper hemisphere, fixed seed.
std::vector<Vec3> upper_directions(std::size_t count) {
  std::mt19937_64 generator(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Vec3> directions(count);
  for (Vec3& d : directions) {
    const double z = unit(generator), phi = 2 * std::numbers::pi * unit(generator);
    const double r = std::sqrt(1 - z * z);
    d = Vec3(r * std::cos(phi), r * std::sin(phi), z);
  }
  return directions;
}

void BM_FaceOf(benchmark::State& state) {
  const Dome dome(static_cast<int>(state.range(0)));
  const auto directions = upper_directions(1 << 16);
  std::size_t next = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(dome.face_of(directions[next]));
    next = (next + 1) & ((1 << 16) - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FaceOf)->Arg(2)->Arg(4)->Arg(8)->Arg(16)->Arg(64);

void BM_DomeConstruction(benchmark::State& state) {
  for (auto _ : state) {
    const Dome dome(static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(dome.faces().data());
  }
}
BENCHMARK(BM_DomeConstruction)->Arg(2)->Arg(4)->Arg(8)->Arg(16)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
