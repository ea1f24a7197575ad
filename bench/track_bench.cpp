// Marker tracking per 1280×720 frame: AprilTag detection plus the head pose, against the
// detector's decimation, with the pose error beside the time (bench/RESULTS.md, Tracking).
//
// The frames: four 20 cm tag36h11 tags on a wall 3 m ahead, seen from three head poses through a
// 65° pinhole camera with mild distortion, rendered with anti-aliasing and 1.5 grey levels of
// noise. The counters: tags found and used, poses solved, mean position and rotation errors. One detector
// thread: run pinned to one core (taskset -c 1 build/bin/track_bench) for the "one core" figure.
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/tag_detector.hpp"

namespace {

using namespace skylit::track;

skylit::camera::CameraCalibration hmd_camera() {
  skylit::camera::CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = skylit::camera::LensModel::Pinhole;
  c.fx = c.fy = 1000;
  c.cx = 639.5;
  c.cy = 359.5;
  c.D = {-0.08, 0.03, 0.0005, -0.0003, 0.0};
  return c;
}

MarkerMap wall_of_four() {
  Eigen::Matrix3d R;
  R.col(0) = Vec3(1, 0, 0);
  R.col(1) = Vec3(0, 0, 1);
  R.col(2) = Vec3(0, -1, 0);  // facing south, towards the head
  MarkerMap map;
  const double spots[4][2] = {{-0.5, 1.9}, {0.5, 1.9}, {-0.5, 1.3}, {0.5, 1.3}};
  for (int i = 0; i < 4; ++i) {
    MarkerTag tag;
    tag.id = i;
    tag.size = 0.20;
    tag.R_site_from_tag = Eigen::Quaterniond(R);
    tag.t_site_from_tag = Vec3(spots[i][0], 3.0, spots[i][1]);
    map.tags.push_back(tag);
  }
  return map;
}

Pose head(const Vec3& position, const Vec3& target, double roll_deg) {
  Pose pose;
  pose.t_site_from_camera = position;
  pose.R_site_from_camera =
      look_at(position, target) * Eigen::Quaterniond(Eigen::AngleAxisd(roll_deg * std::numbers::pi / 180, Vec3::UnitZ()));
  return pose;
}

struct Scene {
  skylit::camera::Lens lens{hmd_camera()};
  MarkerMap map = wall_of_four();
  std::vector<Pose> truths{head(Vec3(0.1, 0.0, 1.6), Vec3(0.0, 3.0, 1.6), 2),
                           head(Vec3(-0.6, 0.2, 1.7), Vec3(0.1, 3.0, 1.5), -4),
                           head(Vec3(0.7, -0.1, 1.5), Vec3(-0.1, 3.0, 1.7), 6)};
  std::vector<cv::Mat> frames;
  Scene() {
    for (std::size_t i = 0; i < truths.size(); ++i) {
      MarkerRenderOptions options;
      options.seed = i + 1;
      frames.push_back(render_markers(map, lens, truths[i], options));
    }
  }
};

const Scene& scene() {
  static const Scene instance;
  return instance;
}

void detect_and_solve(benchmark::State& state, TagDetectorOptions options) {
  const Scene& s = scene();
  options.threads = 1;
  TagDetector detector(options);
  // Accuracy first, outside the timed loop: mean errors over the frames.
  double position_mm = 0, rotation_deg = 0, tags = 0, solved = 0;
  for (std::size_t i = 0; i < s.frames.size(); ++i) {
    const MarkerSolve solve = solve_marker_pose(s.map, s.lens, detector.detect(s.frames[i]));
    tags += static_cast<double>(solve.tags_used.size());
    if (!solve.pose) continue;
    ++solved;
    position_mm += (solve.pose->t_site_from_camera - s.truths[i].t_site_from_camera).norm() * 1e3;
    rotation_deg += solve.pose->R_site_from_camera.angularDistance(s.truths[i].R_site_from_camera) * 180 / std::numbers::pi;
  }
  std::size_t frame = 0;
  for (auto _ : state) {
    const auto detections = detector.detect(s.frames[frame]);
    MarkerSolve solve = solve_marker_pose(s.map, s.lens, detections);
    benchmark::DoNotOptimize(solve);
    frame = (frame + 1) % s.frames.size();
  }
  const double n = static_cast<double>(s.frames.size());
  state.counters["tags"] = tags / n;
  state.counters["solved"] = solved / n;
  state.counters["pos_err_mm"] = solved > 0 ? position_mm / solved : -1;
  state.counters["rot_err_deg"] = solved > 0 ? rotation_deg / solved : -1;
}

// The split at the default: detection alone, and the pose alone from the detections.
void detect_only(benchmark::State& state) {
  const Scene& s = scene();
  TagDetector detector;
  std::size_t frame = 0;
  for (auto _ : state) {
    auto detections = detector.detect(s.frames[frame]);
    benchmark::DoNotOptimize(detections);
    frame = (frame + 1) % s.frames.size();
  }
}

void solve_only(benchmark::State& state) {
  const Scene& s = scene();
  TagDetector detector;
  std::vector<std::vector<TagDetection>> detections;
  for (const cv::Mat& f : s.frames) detections.push_back(detector.detect(f));
  std::size_t frame = 0;
  for (auto _ : state) {
    MarkerSolve solve = solve_marker_pose(s.map, s.lens, detections[frame]);
    benchmark::DoNotOptimize(solve);
    frame = (frame + 1) % s.frames.size();
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (const double decimation : {1.0, 1.5, 2.0, 3.0, 4.0}) {
    char name[64];
    std::snprintf(name, sizeof name, "detect+pose/decimation:%.1f", decimation);
    TagDetectorOptions options;
    options.decimation = decimation;
    benchmark::RegisterBenchmark(name, detect_and_solve, options)->Unit(benchmark::kMillisecond);
  }
  // What the two noise knobs save at the default decimation (the frames carry 1.5 grey levels
  // of noise, as a camera's do): libapriltag's own defaults, then each knob alone.
  TagDetectorOptions plain;
  plain.blur_sigma = 0;
  plain.min_contrast = 5;
  benchmark::RegisterBenchmark("detect+pose/decimation:2.0/blur:0/min_contrast:5", detect_and_solve, plain)
      ->Unit(benchmark::kMillisecond);
  TagDetectorOptions blur_only = plain;
  blur_only.blur_sigma = 0.8;
  benchmark::RegisterBenchmark("detect+pose/decimation:2.0/blur:0.8/min_contrast:5", detect_and_solve, blur_only)
      ->Unit(benchmark::kMillisecond);
  TagDetectorOptions contrast_only = plain;
  contrast_only.min_contrast = 10;
  benchmark::RegisterBenchmark("detect+pose/decimation:2.0/blur:0/min_contrast:10", detect_and_solve, contrast_only)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("detect_only/decimation:2.0", detect_only)->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("pose_only/4_tags", solve_only)->Unit(benchmark::kMicrosecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
