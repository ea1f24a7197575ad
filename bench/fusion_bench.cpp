// Pose fusion cost: per IMU sample (one gyro step), per camera pose (the Kalman update and the
// re-integration of the samples that came after its frame time, against its latency), and per
// pose asked for by the renderer (prediction and jitter filter). A head turning at up to
// 2.5 rad/s, IMU at 1 kHz, camera poses at 30 Hz. Each iteration is one camera frame (33 IMU
// samples, one camera pose, one display pose), 20000 frames per run.
#include <chrono>
#include <cmath>
#include <deque>
#include <vector>

#include <benchmark/benchmark.h>

#include "skylit/track/fusion.hpp"

namespace {

using namespace skylit::track;
using Clock = std::chrono::steady_clock;

constexpr double kImuRate = 1000;
constexpr double kCameraRate = 30;

Eigen::Quaterniond head_rotation(double t) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(0.8 * std::sin(3.0 * t), Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(0.3 * std::sin(2.0 * t), Eigen::Vector3d::UnitX()));
}

// Feeds a fusion one camera frame at a time: the IMU samples of the frame interval, then the
// camera pose of the frame `latency` seconds ago, then one estimate for the display. Each part's
// time is added to its own total.
struct Stream {
  explicit Stream(double latency_seconds) : latency(latency_seconds) {
    for (int i = 0; i < 60; ++i) frame(nullptr, nullptr, nullptr);  // two seconds to settle
  }
  void frame(double* imu_seconds, double* camera_seconds, double* estimate_seconds) {
    const double frame_end = t + 1.0 / kCameraRate;
    samples.clear();
    for (; t < frame_end; t += 1.0 / kImuRate) {
      ImuSample s;
      s.timestamp = t;
      const Eigen::AngleAxisd step(head_rotation(t).conjugate() * head_rotation(t + 1e-4));
      s.gyro = step.axis() * step.angle() / 1e-4 + Eigen::Vector3d(0.01, -0.02, 0.005);
      s.accel = Eigen::Vector3d(0, 9.81, 0);
      samples.push_back(s);
    }
    auto start = Clock::now();
    for (const ImuSample& s : samples) fusion.add_imu(s);
    if (imu_seconds) *imu_seconds += std::chrono::duration<double>(Clock::now() - start).count();
    Pose pose;
    pose.timestamp = t - latency;
    pose.R_site_from_camera = head_rotation(pose.timestamp);
    pose.t_site_from_camera = Eigen::Vector3d(0, 0, 1.6);
    start = Clock::now();
    fusion.add_camera_pose(pose);
    if (camera_seconds) *camera_seconds += std::chrono::duration<double>(Clock::now() - start).count();
    start = Clock::now();
    const FusedPose out = fusion.estimate(t + 0.02);
    benchmark::DoNotOptimize(out);
    if (estimate_seconds) *estimate_seconds += std::chrono::duration<double>(Clock::now() - start).count();
  }
  PoseFusion fusion;
  std::vector<ImuSample> samples;
  double latency;
  double t = 0;
};

void BM_FusionPerImuSample(benchmark::State& state) {
  Stream stream(0.040);
  for (auto _ : state) {
    double seconds = 0;
    stream.frame(&seconds, nullptr, nullptr);
    state.SetIterationTime(seconds / static_cast<double>(stream.samples.size()));  // per sample
  }
}
BENCHMARK(BM_FusionPerImuSample)->UseManualTime()->Iterations(20000)->Unit(benchmark::kNanosecond);

// The camera pose's cost grows with its latency: every IMU sample newer than its frame time is
// integrated again (40 at 1 kHz for 40 ms).
void BM_FusionPerCameraPose(benchmark::State& state) {
  Stream stream(static_cast<double>(state.range(0)) * 1e-3);
  for (auto _ : state) {
    double seconds = 0;
    stream.frame(nullptr, &seconds, nullptr);
    state.SetIterationTime(seconds);
  }
  state.counters["reintegrated"] = static_cast<double>(state.range(0)) * kImuRate * 1e-3;
}
BENCHMARK(BM_FusionPerCameraPose)->UseManualTime()->Iterations(20000)->Unit(benchmark::kMicrosecond)->Arg(0)->Arg(20)->Arg(40)->Arg(80);

void BM_FusionPerDisplayPose(benchmark::State& state) {
  Stream stream(0.040);
  for (auto _ : state) {
    double seconds = 0;
    stream.frame(nullptr, nullptr, &seconds);
    state.SetIterationTime(seconds);
  }
}
BENCHMARK(BM_FusionPerDisplayPose)->UseManualTime()->Iterations(20000)->Unit(benchmark::kNanosecond);

}  // namespace

BENCHMARK_MAIN();
