// Luminance parameters from a 1920×1080 sky frame (target: ≤ 2 ms on one core with the table
// built), at every table step, plus the steps around it: table build, sun detection, and
// linearising an 8-bit frame.
#include <benchmark/benchmark.h>

#include <numbers>

#include "skylit/geom/dome.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/sun.hpp"
#include "skylit/camera/lens.hpp"

namespace {

using namespace skylit;

// A 1920×1080 sensor behind an equidistant fisheye whose 180° circle fills the frame's height.
camera::CameraCalibration hd_fisheye() {
  camera::CameraCalibration c;
  c.image_width = 1920;
  c.image_height = 1080;
  c.fx = c.fy = 540.0 / (std::numbers::pi / 2.0);
  c.cx = 959.5;
  c.cy = 539.5;
  c.D = {0, 0, 0, 0};
  return c;
}

const cv::Mat& clear_sky_frame() {
  static const cv::Mat frame = [] {
    const camera::Lens lens(hd_fisheye());
    const sky::ClearSky sky(Eigen::Vector3d(0.5, -0.4, 0.7).normalized());
    return sky::render_fisheye(lens, sky::sky_function(sky), {.supersample = 1});
  }();
  return frame;
}

void BM_Luminance(benchmark::State& state) {
  const geom::Dome dome(static_cast<int>(state.range(0)));
  const camera::Lens lens(hd_fisheye());
  const sky::SkyTable table = sky::build_sky_table(lens, dome, {.step = static_cast<int>(state.range(1))});
  const cv::Mat& frame = clear_sky_frame();
  for (auto _ : state) {
    sky::Luminance l = sky::compute_luminance(table, dome, frame, cv::Mat(), cv::Mat());
    benchmark::DoNotOptimize(l.faces.data());
  }
  state.counters["samples"] = static_cast<double>(table.sample_count());
  state.counters["runs"] = static_cast<double>(table.runs.size());
}
BENCHMARK(BM_Luminance)->ArgsProduct({{2, 8}, {1, 2, 4}})->Unit(benchmark::kMillisecond)->UseRealTime();

// A fitted basis: its weighted sums per sample, and per face the fit. Arguments: ν, step, the
// sun's exclusion mask (which recomputes the mass of the faces it touches), and the AVX2 pass (1,
// where the CPU has it) or the portable one (0).
void run_fitted_pass(benchmark::State& state, geom::DomeBasis basis) {
  const geom::Dome dome(static_cast<int>(state.range(0)));
  const camera::Lens lens(hd_fisheye());
  const sky::SkyTable table =
      sky::build_sky_table(lens, dome, {.step = static_cast<int>(state.range(1)), .basis = basis});
  const cv::Mat& frame = clear_sky_frame();
  cv::Mat exclude;
  if (state.range(2)) {
    exclude = cv::Mat(frame.size(), CV_8UC1, cv::Scalar(0));
    for (int y = 288; y <= 312; ++y) {  // a sun's disc with its halo, 25 pixels across
      for (int x = 1288; x <= 1312; ++x) exclude.at<std::uint8_t>(y, x) = (x - 1300) * (x - 1300) + (y - 300) * (y - 300) <= 144 ? 255 : 0;
    }
  }
  sky::LuminanceOptions options;
  options.use_simd = state.range(3) != 0;
  for (auto _ : state) {
    sky::Luminance l = sky::compute_luminance(table, dome, frame, cv::Mat(), exclude, options);
    benchmark::DoNotOptimize(l.faces.data());
  }
  state.counters["samples"] = static_cast<double>(table.sample_count());
  state.counters["runs"] = static_cast<double>(table.runs.size());
}

// ν 2 and 8 at steps 1, 2, 4 on the AVX2 pass; at step 1 also with the sun's mask and on the
// portable pass.
void fitted_pass_arguments(benchmark::internal::Benchmark* b) {
  b->ArgsProduct({{2, 8}, {1, 2, 4}, {0}, {1}})
      ->Args({2, 1, 1, 1})
      ->Args({8, 1, 1, 1})
      ->Args({2, 1, 0, 0})
      ->Args({8, 1, 0, 0})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
}

// The corners basis: three weighted sums per sample and a 3×3 fit per face.
void BM_LuminanceCorners(benchmark::State& state) { run_fitted_pass(state, geom::DomeBasis::Corners); }
BENCHMARK(BM_LuminanceCorners)->Apply(fitted_pass_arguments);

// The quadratics basis: six monomial sums per sample (the same lanes as the corners and three
// more) and a 6×6 fit per face.
void BM_LuminanceQuadratics(benchmark::State& state) { run_fitted_pass(state, geom::DomeBasis::Quadratics); }
BENCHMARK(BM_LuminanceQuadratics)->Apply(fitted_pass_arguments);

void BM_BuildTable(benchmark::State& state) {
  const geom::Dome dome(static_cast<int>(state.range(0)));
  const camera::Lens lens(hd_fisheye());
  for (auto _ : state) {
    sky::SkyTable t = sky::build_sky_table(lens, dome);
    benchmark::DoNotOptimize(t.runs.data());
  }
}
BENCHMARK(BM_BuildTable)->Arg(2)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_BuildTableCorners(benchmark::State& state) {
  const geom::Dome dome(static_cast<int>(state.range(0)));
  const camera::Lens lens(hd_fisheye());
  for (auto _ : state) {
    sky::SkyTable t = sky::build_sky_table(lens, dome, {.basis = geom::DomeBasis::Corners});
    benchmark::DoNotOptimize(t.runs.data());
  }
}
BENCHMARK(BM_BuildTableCorners)->Arg(2)->Arg(8)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_SunDetection(benchmark::State& state) {
  const camera::Lens lens(hd_fisheye());
  const sky::SunDetector detector(lens, cv::Mat());
  const cv::Mat& frame = clear_sky_frame();
  for (auto _ : state) {
    sky::SunDetection d = detector.detect(frame, cv::Mat());
    benchmark::DoNotOptimize(d.sun);
  }
}
BENCHMARK(BM_SunDetection)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Linearise8Bit(benchmark::State& state) {
  const cv::Mat frame8 = sky::to_8bit(clear_sky_frame(), 0.05);
  const sky::ResponseCurve srgb = sky::ResponseCurve::srgb(8);
  for (auto _ : state) {
    sky::RadianceFrame f = sky::linearise(frame8, srgb, {});
    benchmark::DoNotOptimize(f.radiance.data);
  }
}
BENCHMARK(BM_Linearise8Bit)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
