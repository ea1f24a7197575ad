// A stereo camera's marker pose against either camera's alone (bench/RESULTS.md, "Marker tracking
// with a stereo camera"): errors over many synthetic heads 2 to 15 m from the tags, the flags'
// shares and the solve time; then rendered pairs through the detector, with the detection time.
// Accepted: what the tracker keeps at its defaults (not high_error, ambiguous nor single distant).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/track/marker_pose_stereo.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/tag_detector.hpp"

namespace {

using namespace skylit::track;
using Clock = std::chrono::steady_clock;

// track_bench's HMD camera (65° across 1280×720, mild distortion), twice, 64 mm apart.
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

// track_bench's wall: four 20 cm tags 1.0 m × 0.6 m apart on the wall y = 3 m, facing south.
MarkerMap wall_of_four() {
  Eigen::Matrix3d R;
  R.col(0) = Vec3(1, 0, 0);
  R.col(1) = Vec3(0, 0, 1);
  R.col(2) = Vec3(0, -1, 0);
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

// Corners of the tags wholly inside the frame, plus Gaussian noise (pixels).
std::vector<TagDetection> corners_seen(const MarkerMap& map, const skylit::camera::Lens& lens, const Pose& camera,
                                       double noise_px, std::mt19937& random) {
  std::normal_distribution<double> noise(0.0, noise_px);
  const auto& c = lens.calibration();
  std::vector<TagDetection> detections;
  for (const MarkerTag& tag : map.tags) {
    TagDetection d;
    d.id = tag.id;
    bool inside = true;
    const auto corners = tag_corners_in_site(tag);
    for (std::size_t k = 0; k < 4 && inside; ++k) {
      const Vec3 p = camera.R_site_from_camera.conjugate() * (corners[k] - camera.t_site_from_camera);
      const std::optional<Eigen::Vector2d> pixel = p.z() > 0 ? lens.project(p) : std::nullopt;
      inside = pixel && pixel->x() >= 0 && pixel->y() >= 0 && pixel->x() <= c.image_width - 1 && pixel->y() <= c.image_height - 1;
      if (inside) d.corners[k] = *pixel + Eigen::Vector2d(noise(random), noise(random));
    }
    if (inside) detections.push_back(d);
  }
  return detections;
}

// One method's solves against the truth.
struct Tally {
  std::vector<double> position_mm, along_mm, across_mm, rotation_deg, time_us;
  std::vector<double> accepted_position_mm;  // of the solves the tracker keeps by default
  int solves = 0, no_pose = 0, ambiguous = 0, single_distant = 0, accepted = 0, flipped = 0, accepted_flipped = 0;

  void add(const MarkerSolve& solve, const Pose& truth, double time_us_taken) {
    ++solves;
    time_us.push_back(time_us_taken);
    if (!solve.pose) {
      ++no_pose;
      return;
    }
    const Vec3 error = solve.pose->t_site_from_camera - truth.t_site_from_camera;
    const Vec3 axis = truth.R_site_from_camera * Vec3::UnitZ();
    const double along = error.dot(axis);
    position_mm.push_back(error.norm() * 1e3);
    along_mm.push_back(std::abs(along) * 1e3);
    across_mm.push_back((error - along * axis).norm() * 1e3);
    const double rotation = solve.pose->R_site_from_camera.angularDistance(truth.R_site_from_camera) * 180 / std::numbers::pi;
    rotation_deg.push_back(rotation);
    ambiguous += solve.ambiguous ? 1 : 0;
    single_distant += solve.single_distant_tag ? 1 : 0;
    const bool kept = !solve.high_error && !solve.ambiguous && !solve.single_distant_tag;
    const bool flip = rotation > 5.0;  // the wrong one of two planar solutions, in practice
    accepted += kept ? 1 : 0;
    flipped += flip ? 1 : 0;
    accepted_flipped += kept && flip ? 1 : 0;
    if (kept) accepted_position_mm.push_back(error.norm() * 1e3);
  }
};

double rms(const std::vector<double>& v) {
  double sum = 0;
  for (const double x : v) sum += x * x;
  return v.empty() ? NAN : std::sqrt(sum / static_cast<double>(v.size()));
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

double share(int count, int of) { return of > 0 ? 100.0 * count / of : NAN; }

void print_row(const char* band, const char* method, const Tally& t) {
  std::printf("| %s | %s | %.1f / %.1f | %.1f / %.1f | %.1f / %.1f | %.3f / %.3f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.0f |\n",
              band, method, rms(t.position_mm), percentile(t.position_mm, 0.95), rms(t.along_mm), percentile(t.along_mm, 0.95),
              rms(t.across_mm), percentile(t.across_mm, 0.95), rms(t.rotation_deg), percentile(t.rotation_deg, 0.95),
              share(t.ambiguous, t.solves), share(t.single_distant, t.solves), share(t.flipped, t.solves),
              share(t.accepted, t.solves), share(t.accepted_flipped, t.solves), rms(t.accepted_position_mm),
              percentile(t.time_us, 0.5));
}

struct Rig {
  skylit::camera::Lens left{hmd_camera()};
  skylit::camera::Lens right{hmd_camera()};
  StereoExtrinsics extrinsics{Eigen::Matrix3d::Identity(), Vec3(-0.064, 0, 0)};
};

struct Methods {
  Tally left, right, both;
};

template <typename F>
double time_us(F&& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count();
}

// Exact corners plus σ 0.3 px, heads in distance bands, looking at the wall from aside.
void corner_noise_study(const char* title, const MarkerMap& map, int heads_per_band, unsigned seed) {
  const Rig rig;
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const double bands[][2] = {{2, 4}, {4, 6}, {6, 8}, {8, 11}, {11, 15}};
  std::printf("\n### %s: corners with σ 0.3 px of noise, %d heads per band\n\n", title, heads_per_band);
  std::printf("| distance | cameras | position mm RMS / p95 | along the axis | across it | rotation ° RMS / p95 | "
              "ambiguous %% | single distant %% | rotation > 5° %% | accepted %% | accepted, > 5° %% | accepted: position mm RMS | "
              "solve µs median |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  Methods all;
  for (const auto& band : bands) {
    Methods in_band;
    int kept = 0;
    while (kept < heads_per_band) {
      const double distance = band[0] + (band[1] - band[0]) * (0.5 + 0.5 * uniform(random));
      const Pose truth = head(Vec3(0.25 * distance * uniform(random), 3.0 - distance, 1.6 + 0.2 * uniform(random)),
                              Vec3(0.3 * uniform(random), 3.0, 1.6 + 0.2 * uniform(random)), 8 * uniform(random));
      const auto l = corners_seen(map, rig.left, truth, 0.3, random);
      const auto r = corners_seen(map, rig.right, right_camera_pose(truth, rig.extrinsics), 0.3, random);
      if (l.empty() || r.empty()) continue;  // compared where both cameras see a tag
      ++kept;
      MarkerSolve left, right, both;
      const double t_left = time_us([&] { left = solve_marker_pose(map, rig.left, l); });
      const double t_right = time_us([&] { right = as_left_camera(solve_marker_pose(map, rig.right, r), rig.extrinsics); });
      const double t_both = time_us([&] {
        both = solve_marker_pose_stereo(map, rig.left, rig.right, rig.extrinsics.R_right_from_left,
                                        rig.extrinsics.t_right_from_left, l, r);
      });
      for (Methods* m : {&in_band, &all}) {
        m->left.add(left, truth, t_left);
        m->right.add(right, truth, t_right);
        m->both.add(both, truth, t_both);
      }
    }
    char name[32];
    std::snprintf(name, sizeof name, "%.0f–%.0f m", band[0], band[1]);
    print_row(name, "left", in_band.left);
    print_row(name, "right", in_band.right);
    print_row(name, "**both**", in_band.both);
  }
  print_row("2–15 m", "left", all.left);
  print_row("2–15 m", "right", all.right);
  print_row("2–15 m", "**both**", all.both);
  std::printf("\nboth / left, 2–15 m: position RMS %.2f, p95 %.2f; along the axis RMS %.2f; across RMS %.2f; rotation RMS "
              "%.2f, p95 %.2f; solve time %.2f\n",
              rms(all.both.position_mm) / rms(all.left.position_mm),
              percentile(all.both.position_mm, 0.95) / percentile(all.left.position_mm, 0.95),
              rms(all.both.along_mm) / rms(all.left.along_mm), rms(all.both.across_mm) / rms(all.left.across_mm),
              rms(all.both.rotation_deg) / rms(all.left.rotation_deg),
              percentile(all.both.rotation_deg, 0.95) / percentile(all.left.rotation_deg, 0.95),
              percentile(all.both.time_us, 0.5) / percentile(all.left.time_us, 0.5));
}

// Rendered pairs (track_bench's renderer: anti-aliased, 1.5 grey levels of noise) through the
// detector at its defaults: the errors, and the detection time of one frame against two.
void rendered_study(int heads, unsigned seed) {
  const Rig rig;
  const MarkerMap map = wall_of_four();
  TagDetector detector;
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Methods methods;
  std::vector<double> detect_one_ms, detect_two_ms;
  int kept = 0;
  while (kept < heads) {
    const double distance = 2.0 + 6.0 * (kept + 0.5) / heads;
    const Pose truth = head(Vec3(0.2 * distance * uniform(random), 3.0 - distance, 1.6 + 0.2 * uniform(random)),
                            Vec3(0.3 * uniform(random), 3.0, 1.6 + 0.2 * uniform(random)), 8 * uniform(random));
    MarkerRenderOptions options;
    options.seed = 2 * static_cast<std::uint64_t>(kept) + 1;
    const cv::Mat left_frame = render_markers(map, rig.left, truth, options);
    options.seed += 1;
    const cv::Mat right_frame = render_markers(map, rig.right, right_camera_pose(truth, rig.extrinsics), options);
    std::vector<TagDetection> l, r;
    const double t_one = time_us([&] { l = detector.detect(left_frame); });
    const double t_other = time_us([&] { r = detector.detect(right_frame); });
    if (l.empty() || r.empty()) continue;
    ++kept;
    detect_one_ms.push_back(t_one / 1e3);
    detect_two_ms.push_back((t_one + t_other) / 1e3);
    MarkerSolve left, right, both;
    const double t_left = time_us([&] { left = solve_marker_pose(map, rig.left, l); });
    const double t_right = time_us([&] { right = as_left_camera(solve_marker_pose(map, rig.right, r), rig.extrinsics); });
    const double t_both = time_us([&] {
      both = solve_marker_pose_stereo(map, rig.left, rig.right, rig.extrinsics.R_right_from_left,
                                      rig.extrinsics.t_right_from_left, l, r);
    });
    methods.left.add(left, truth, t_left);
    methods.right.add(right, truth, t_right);
    methods.both.add(both, truth, t_both);
  }
  std::printf("\n### Rendered pairs through the detector, the wall of four, %d heads 2–8 m\n\n", heads);
  std::printf("| distance | cameras | position mm RMS / p95 | along the axis | across it | rotation ° RMS / p95 | "
              "ambiguous %% | single distant %% | rotation > 5° %% | accepted %% | accepted, > 5° %% | accepted: position mm RMS | "
              "solve µs median |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  print_row("2–8 m", "left", methods.left);
  print_row("2–8 m", "right", methods.right);
  print_row("2–8 m", "**both**", methods.both);
  std::printf("\ndetection (median): one frame %.2f ms, both frames %.2f ms\n", percentile(detect_one_ms, 0.5),
              percentile(detect_two_ms, 0.5));
}

}  // namespace

// stereo_track_bench [heads per distance band, default 400; a quarter as many rendered] [seed, default 22]
int main(int argc, char** argv) {
  const int heads_per_band = argc > 1 ? std::max(1, std::atoi(argv[1])) : 400;
  const unsigned seed = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 22u;
  const MarkerMap four = wall_of_four();
  MarkerMap one;
  one.family = four.family;
  one.tags = {four.tags[1]};
  corner_noise_study("The wall of four 20 cm tags", four, heads_per_band, seed);
  corner_noise_study("One 20 cm tag of the wall", one, heads_per_band, seed + 1);
  rendered_study(std::max(6, heads_per_band / 4), seed + 2);
  return 0;
}
