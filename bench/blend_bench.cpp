// CPU blend of shadow ratios against the machine's memory floor.
//
// The blend reads every active basis layer once per sky, so on a plane that does not fit in the
// caches its time is bounded below by (bytes of half basis images) / (memory bandwidth). This
// program measures the bandwidth in the same run (buffers ≥ 4× the L3 cache, best of several,
// per thread count) in three conventions and reports per benchmark:
//   floor_ms    basis bytes / memcpy rate (bytes copied per second)   ratio         time / floor_ms
//   copy_GBps   the memcpy rate                                        (the target: ratio ≤ 1.3)
//   ratio_stream  time / (basis bytes / STREAM bandwidth), STREAM counting bytes read + written,
//               i.e. twice the memcpy rate: half floor_ms
//   read_GBps   bytes read per second by threads that only read        ratio_read    time / (basis bytes / read_GBps)
//   bytes_per_second  basis bytes / blend time
// "cold" runs evict the caches before every iteration (the floor's premise); "warm" ones blend
// the same planes again and again, as a live service does when they fit in the last-level cache.
//
//   blend_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//               [--pca K] [--pca-tiles 0,64] [--pca-frequencies 2,8] [--pca-size 512] [--pca-repeats 9] [--pca-only]
//
// --pca K (default 0: off) adds, after the benchmarks, the table "PCA forms": per ν in
// --pca-frequencies (default 2, 8: the 40- and 640-face cases above) one plane of --pca-size²
// blended by blend_cpu (default options: all hardware threads, SIMD where the CPU has it; warm:
// the same plane again and again), in its full form (10ν² layers) beside its PCA form
// (BasisImages::projection) with K + 1 stored layers, untiled and tiled (clustered PCA,
// BasisImages::tile = T for each T > 0 in --pca-tiles). Median and minimum of --pca-repeats calls
// after two warm-up calls. Synthetic PCA form: K + 1 half layers, the mean in [0.3, 0.7] and K
// eigen-images in [-1, 1]; projection n × (tile_count · (K + 1)), column t · (K + 1) = A_l (tile t's
// mean) and A_l · [-0.1, 0.1] elsewhere, so that T stays near [0, 1]. --pca-only skips the
// benchmarks (and the bandwidth measurements) and prints only that table.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <benchmark/benchmark.h>

#include "skylit/blend/workers.hpp"
#include "skylit/blend/half.hpp"
#include "synthetic_pca.hpp"
#include "skylit/blend/cpu_blend.hpp"

namespace {

using skylit::blend::BasisImages;
using skylit::blend::BlendOptions;
using skylit::blend::BlendWeights;
using Clock = std::chrono::steady_clock;

constexpr int kSide = 512;

std::size_t l3_bytes() {
  const long l3 = ::sysconf(_SC_LEVEL3_CACHE_SIZE);
  return l3 > 0 ? static_cast<std::size_t>(l3) : std::size_t{64} << 20;
}

// A page-aligned byte buffer, touched so that its pages exist before anything is timed.
struct Buffer {
  explicit Buffer(std::size_t n) : size(n), data(static_cast<char*>(std::aligned_alloc(4096, (n + 4095) / 4096 * 4096))) {
    if (!data) throw std::bad_alloc();
    std::memset(data.get(), 1, size);
  }
  struct Free {
    void operator()(char* p) const { std::free(p); }
  };
  std::size_t size;
  std::unique_ptr<char, Free> data;
};

// Best of `rounds` runs of `job(thread, offset, bytes)` by `threads` threads over disjoint slices
// of `bytes` in all (each a multiple of 4 KiB); returns seconds.
template <class Job>
double best_seconds(std::size_t bytes, int threads, int rounds, const Job& job) {
  const std::size_t slice = bytes / static_cast<std::size_t>(threads) / 4096 * 4096;
  double best = 1e30;
  for (int r = 0; r < rounds; ++r) {
    const auto start = Clock::now();
    {
      std::vector<std::jthread> pool;
      for (int t = 0; t < threads; ++t) {
        pool.emplace_back([&, t] { job(t, static_cast<std::size_t>(t) * slice, slice); });
      }
    }
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return best * static_cast<double>(bytes) / static_cast<double>(slice * static_cast<std::size_t>(threads));
}

// The memcpy rate: bytes copied per second (buffer's first half into its second half).
double copy_rate(Buffer& buffer, int threads, int rounds) {
  const std::size_t half = buffer.size / 2;
  const double seconds = best_seconds(half, threads, rounds, [&](int, std::size_t at, std::size_t n) {
    std::memcpy(buffer.data.get() + half + at, buffer.data.get() + at, n);
  });
  return static_cast<double>(half) / seconds;
}

// Bytes read per second by threads that sum 64-bit words (four independent sums, so that the
// loop is not bound by its additions).
double read_rate(const Buffer& buffer, int threads, int rounds) {
  const std::size_t bytes = buffer.size / 2;
  std::vector<std::uint64_t> sums(static_cast<std::size_t>(threads));
  const double seconds = best_seconds(bytes, threads, rounds, [&](int t, std::size_t at, std::size_t n) {
    const auto* p = reinterpret_cast<const std::uint64_t*>(buffer.data.get() + at);
    std::uint64_t s0 = 0, s1 = 0, s2 = 0, s3 = 0;
    for (std::size_t i = 0; i < n / 8; i += 4) {
      s0 += p[i];
      s1 += p[i + 1];
      s2 += p[i + 2];
      s3 += p[i + 3];
    }
    sums[static_cast<std::size_t>(t)] = s0 + s1 + s2 + s3;
  });
  benchmark::DoNotOptimize(sums.data());
  return static_cast<double>(bytes) / seconds;
}

// Reads `bytes` of the buffer so that whatever the blend read before is no longer cached.
void evict_caches(const Buffer& buffer, std::size_t bytes) {
  const auto* p = reinterpret_cast<const std::uint64_t*>(buffer.data.get());
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < std::min(bytes, buffer.size) / 8; i += 8) sum += p[i];
  benchmark::DoNotOptimize(sum);
}

// A plane of `layers` faces over a horizontal ground (every face lit and seen, all active):
// B = A·f with f in [0, 1], stored as half; a sun with partial visibility.
struct Scene {
  std::vector<BasisImages> planes;
  std::vector<BlendWeights> weights;
  std::vector<float> visibility;
  std::size_t basis_bytes = 0;
  std::vector<Eigen::Vector3d> S;  // the sky, one RGB value per layer
  skylit::blend::SunLight sun;
};

Scene make_scene(int layers, int planes, int side = kSide) {
  Scene scene;
  std::uint64_t state = 0x9e3779b97f4a7c15ull * static_cast<std::uint64_t>(layers);
  const auto next = [&state] {  // xorshift64*: fast, and good enough for texel values
    state ^= state >> 12;
    state ^= state << 25;
    state ^= state >> 27;
    return static_cast<double>((state * 0x2545f4914f6cdd1dull) >> 11) * 0x1p-53;
  };
  const double omega = 2.0 * std::numbers::pi / layers;
  std::vector<Eigen::Vector3d> S;
  for (int i = 0; i < layers; ++i) S.emplace_back(0.5 + next(), 0.5 + next(), 0.5 + next());
  skylit::blend::SunLight sun;
  sun.direction = skylit::geom::Vec3(0.5, 0.2, 0.8).normalized();
  sun.energy = Eigen::Vector3d(3.0, 2.9, 2.7);
  for (int j = 0; j < planes; ++j) {
    BasisImages basis;
    basis.name = "plane" + std::to_string(j);
    basis.width = side;
    basis.height = side;
    basis.layers = layers;
    for (int i = 0; i < layers; ++i) basis.unoccluded.push_back(omega * (0.2 + 0.8 * next()));
    basis.half.resize(basis.texel_count() * static_cast<std::size_t>(layers));
    for (int i = 0; i < layers; ++i) {
      std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(i) * basis.texel_count();
      const double a = basis.unoccluded[static_cast<std::size_t>(i)];
      for (std::size_t t = 0; t < basis.texel_count(); ++t) {
        layer[t] = skylit::blend::float_to_half(static_cast<float>(a * std::min(1.0, 1.3 * next())));
      }
    }
    scene.weights.push_back(skylit::blend::blend_weights(basis, S, sun));
    scene.basis_bytes += basis.half.size() * sizeof(std::uint16_t);
    scene.planes.push_back(std::move(basis));
  }
  scene.visibility.resize(static_cast<std::size_t>(side) * static_cast<std::size_t>(side));
  for (float& v : scene.visibility) v = next() < 0.3 ? 0.0f : 1.0f;
  scene.S = std::move(S);
  scene.sun = sun;
  return scene;
}

// --pca and its companions (see the header); taken out of argv before Google Benchmark sees it.
struct PcaSettings {
  int components = 0;  // K; 0: no PCA table
  std::vector<int> tiles{0, 64};
  std::vector<int> frequencies{2, 8};
  int size = kSide;
  int repeats = 9;
  bool only = false;
};

[[noreturn]] void pca_usage(const std::string& problem) {
  std::fprintf(stderr,
               "blend_bench: %s\nusage: blend_bench [benchmark options] [--pca K] [--pca-tiles 0,64] "
               "[--pca-frequencies 2,8] [--pca-size 512] [--pca-repeats 9] [--pca-only]\n",
               problem.c_str());
  std::exit(2);
}

int pca_integer(const std::string& text, const std::string& option, int least) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(text, &used);
    if (used == text.size() && value >= least) return value;
  } catch (const std::exception&) {
  }
  pca_usage("option " + option + " needs integers >= " + std::to_string(least) + ", got '" + text + "'");
}

std::vector<int> pca_list(const std::string& text, const std::string& option, int least) {
  std::vector<int> values;
  std::stringstream stream(text);
  std::string part;
  while (std::getline(stream, part, ',')) values.push_back(pca_integer(part, option, least));
  if (values.empty()) pca_usage("option " + option + " needs a list");
  return values;
}

// Reads the --pca options and removes them from argv (argc updated).
PcaSettings parse_pca(int& argc, char** argv) {
  PcaSettings s;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) pca_usage("option " + arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--pca") {
      s.components = pca_integer(value(), arg, 0);
    } else if (arg == "--pca-tiles") {
      s.tiles = pca_list(value(), arg, 0);
    } else if (arg == "--pca-frequencies") {
      s.frequencies = pca_list(value(), arg, 1);
    } else if (arg == "--pca-size") {
      s.size = pca_integer(value(), arg, 1);
    } else if (arg == "--pca-repeats") {
      s.repeats = pca_integer(value(), arg, 1);
    } else if (arg == "--pca-only") {
      s.only = true;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  argv[argc] = nullptr;
  return s;
}


double median_of(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// The table "PCA forms" (see the header), on stdout.
void pca_table(const PcaSettings& settings) {
  std::printf("\nPCA forms: blend_cpu per plane of %d² (default options: all hardware threads, %s; warm), "
              "median and minimum of %d calls:\n\n",
              settings.size, skylit::blend::blend_simd_available() ? "avx2" : "portable", settings.repeats);
  std::printf("| form | ν (n layers) | stored layers | basis bytes | median | min | median / full |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  std::fflush(stdout);
  std::vector<int> tiles{0};
  for (const int tile : settings.tiles) {
    if (std::find(tiles.begin(), tiles.end(), tile) == tiles.end()) tiles.push_back(tile);
  }
  for (const int frequency : settings.frequencies) {
    const int layers = 10 * frequency * frequency;
    const Scene scene = make_scene(layers, 1, settings.size);
    const BasisImages& full = scene.planes.front();
    std::vector<BasisImages> forms;
    for (const int tile : tiles) {
      forms.push_back(skylit::bench::synthetic_pca_basis(settings.size, full.unoccluded, settings.components, tile,
                                          0xca5e0000ull + static_cast<std::uint64_t>(frequency)));
    }
    // The cropped form at the share the sample site's ground keeps at ν = 8 (43% of the texels).
    forms.push_back(skylit::bench::synthetic_cropped_basis(full, 0.43, 0xc0ull + static_cast<std::uint64_t>(frequency)));
    std::vector<float> out(3 * full.texel_count());
    double full_median = 0.0;
    for (std::size_t f = 0; f <= forms.size(); ++f) {
      const BasisImages& basis = f == 0 ? full : forms[f - 1];
      const BlendWeights weights = skylit::blend::blend_weights(basis, scene.S, scene.sun);
      const auto call = [&] { return skylit::blend::blend_cpu(basis, weights, scene.visibility, out); };
      for (int w = 0; w < 2; ++w) benchmark::DoNotOptimize(call());
      std::vector<double> seconds;
      for (int r = 0; r < settings.repeats; ++r) {
        const auto start = Clock::now();
        benchmark::DoNotOptimize(call());
        seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
        benchmark::ClobberMemory();
      }
      const double median = median_of(seconds);
      if (f == 0) full_median = median;
      const std::string name =
          f == 0 ? std::string("full")
          : basis.cropped() ? std::string("cropped to 43% of the texels")
                 : "PCA K=" + std::to_string(settings.components) +
                       (basis.tile > 0 ? ", tile " + std::to_string(basis.tile) + " (" +
                                             std::to_string(basis.tile_count()) + " tiles)"
                                       : std::string(", untiled"));
      std::printf("| %s | %d (%d) | %d | %.1f MiB | %.3f ms | %.3f ms | %.3f× |\n", name.c_str(), frequency, layers,
                  basis.layers, static_cast<double>(basis.half.size() * sizeof(std::uint16_t)) / 1048576.0, median * 1e3,
                  *std::min_element(seconds.begin(), seconds.end()) * 1e3, median / full_median);
      std::fflush(stdout);
    }
  }
}

struct Setup {
  const Scene* scene;
  int threads;
  bool simd;
  bool cold;
  double copy_rate;     // bytes copied per second, this thread count
  double read_rate;     // bytes read per second, this thread count
  const Buffer* evict;  // for cold runs
  skylit::blend::BlendWorkers* workers;  // kept between calls, as the live service does
};

void blend_planes(benchmark::State& state, const Setup& setup) {
  const Scene& scene = *setup.scene;
  BlendOptions options;
  options.threads = setup.threads;
  options.workers = setup.workers;
  options.use_simd = setup.simd;
  std::vector<float> out(3 * scene.planes.front().texel_count());
  double seconds = 0.0;
  for (auto _ : state) {
    if (setup.cold) evict_caches(*setup.evict, 2 * l3_bytes());
    const auto start = Clock::now();
    for (std::size_t j = 0; j < scene.planes.size(); ++j) {
      benchmark::DoNotOptimize(skylit::blend::blend_cpu(scene.planes[j], scene.weights[j], scene.visibility, out, options));
    }
    const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    state.SetIterationTime(elapsed);
    seconds += elapsed;
    benchmark::ClobberMemory();
  }
  const double bytes = static_cast<double>(scene.basis_bytes);
  const double floor = bytes / setup.copy_rate;
  const double time = seconds / static_cast<double>(state.iterations());
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(scene.basis_bytes));
  state.counters["floor_ms"] = floor * 1e3;
  state.counters["ratio"] = time / floor;
  state.counters["ratio_stream"] = time / (bytes / (2.0 * setup.copy_rate));
  state.counters["copy_GBps"] = setup.copy_rate * 1e-9;
  state.counters["read_GBps"] = setup.read_rate * 1e-9;
  state.counters["ratio_read"] = time / (bytes / setup.read_rate);
  state.SetLabel(std::string(setup.simd && skylit::blend::blend_simd_available() ? "avx2" : "portable") +
                 (setup.cold ? ", cold" : ", warm"));
}

}  // namespace

int main(int argc, char** argv) {
  const PcaSettings pca = parse_pca(argc, argv);
  if (pca.only) {
    if (pca.components == 0) pca_usage("--pca-only needs --pca K > 0");
    pca_table(pca);
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  const std::size_t copy_bytes = 2 * std::max<std::size_t>(4 * l3_bytes(), std::size_t{256} << 20);
  std::fprintf(stderr, "L3 %.0f MiB; copy buffer 2 x %.0f MiB; building scenes ...\n", l3_bytes() / 1048576.0,
               copy_bytes / 2 / 1048576.0);
  Buffer copy_buffer(copy_bytes);
  const int max_threads = 2;
  std::vector<double> copy(max_threads + 1);
  std::vector<double> read(max_threads + 1);
  for (int t = 1; t <= max_threads; ++t) {
    const auto at = static_cast<std::size_t>(t);
    copy[at] = copy_rate(copy_buffer, t, 7);
    read[at] = read_rate(copy_buffer, t, 7);
    std::fprintf(stderr, "%d thread%s: memcpy rate %.2f GB/s (STREAM read + write %.2f GB/s), read %.2f GB/s\n", t,
                 t > 1 ? "s" : "", copy[at] * 1e-9, 2.0 * copy[at] * 1e-9, read[at] * 1e-9);
  }
  // 40 faces × 4 planes of 512² (84 MB), 640 faces × 1 plane of 512² (335 MB).
  const Scene forty = make_scene(40, 4);
  const Scene six_forty = make_scene(640, 1);
  std::vector<std::unique_ptr<skylit::blend::BlendWorkers>> workers(max_threads + 1);
  for (int t = 1; t <= max_threads; ++t) {
    workers[static_cast<std::size_t>(t)] = std::make_unique<skylit::blend::BlendWorkers>(t);
  }

  // On a shared machine other work only ever slows a run down: the minimum over repetitions is
  // reported beside the median.
  const auto smallest = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  struct Case {
    const char* name;
    const Scene* scene;
    int iterations;
  };
  for (const Case& c : {Case{"40faces_4planes_512", &forty, 30}, Case{"640faces_1plane_512", &six_forty, 10}}) {
    for (const bool cold : {true, false}) {
      for (int t = 1; t <= max_threads; ++t) {
        const Setup setup{c.scene, t, true, cold, copy[static_cast<std::size_t>(t)], read[static_cast<std::size_t>(t)], &copy_buffer,
                          workers[static_cast<std::size_t>(t)].get()};
        const std::string name = std::string("blend/") + c.name + (cold ? "/cold" : "/warm") + "/threads:" +
                                 std::to_string(t);
        benchmark::RegisterBenchmark(name.c_str(), [setup](benchmark::State& s) { blend_planes(s, setup); })
            ->UseManualTime()
            ->Iterations(c.iterations)
            ->Unit(benchmark::kMillisecond)
            ->ComputeStatistics("min", smallest);
      }
    }
    // The portable kernel, for machines without AVX2/F16C.
    const Setup portable{c.scene, 1, false, true, copy[1], read[1], &copy_buffer, workers[1].get()};
    const std::string name = std::string("blend/") + c.name + "/cold/portable/threads:1";
    benchmark::RegisterBenchmark(name.c_str(), [portable](benchmark::State& s) { blend_planes(s, portable); })
        ->UseManualTime()
        ->Iterations(c.iterations)
        ->Unit(benchmark::kMillisecond)
        ->ComputeStatistics("min", smallest);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (pca.components > 0) pca_table(pca);
  return 0;
}
