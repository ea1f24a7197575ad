// A stereo camera's pose from both cameras' tags: exact and noisy corners (the joint solve),
// tags seen by one camera only, rendered pairs through the stereo tracker, and its bad inputs.
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../support/temp_dir.hpp"
#include "marker_scene.hpp"
#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/track/marker_pose_stereo.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/marker_tracker.hpp"

namespace stereo_tracking_test {  // named, not anonymous: the test program is one unity build

using namespace skylit::track;
using namespace marker_scene;
using skylit::camera::Lens;
using skylit::camera::StereoCalibration;

constexpr double kDegree = std::numbers::pi / 180;

// Two of the tests' HMD cameras 64 mm apart, the right one a little turned and of a slightly
// different lens, as a calibrated stereo camera is.
StereoCalibration stereo_camera() {
  StereoCalibration s;
  s.file = "hmd_stereo.yaml";
  s.left = hmd_camera();
  s.right = hmd_camera();
  s.right.cx = 642.0;
  s.right.cy = 357.5;
  s.right.D = {-0.07, 0.025, -0.0004, 0.0002, 0.0};
  s.R_right_from_left = (Eigen::AngleAxisd(0.4 * kDegree, Vec3::UnitY()) * Eigen::AngleAxisd(-0.2 * kDegree, Vec3::UnitX()))
                            .toRotationMatrix();
  s.t_right_from_left = Vec3(-0.064, 0.001, 0.0005);
  return s;
}

StereoExtrinsics extrinsics_of(const StereoCalibration& s) { return {s.R_right_from_left, s.t_right_from_left}; }

// The corners of the map's tags wholly inside the frame, as a perfect detector would report them,
// plus Gaussian noise (pixels).
std::vector<TagDetection> corners_seen(const MarkerMap& map, const Lens& lens, const Pose& camera, double noise_px,
                                       std::mt19937& random) {
  std::normal_distribution<double> noise(0.0, 1.0);
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
      if (inside) d.corners[k] = *pixel + noise_px * Eigen::Vector2d(noise(random), noise(random));
    }
    if (inside) detections.push_back(d);
  }
  return detections;
}

struct StereoScene {
  StereoCalibration calibration = stereo_camera();
  Lens left{calibration.left};
  Lens right{calibration.right};
  StereoExtrinsics extrinsics = extrinsics_of(calibration);

  MarkerSolve solve(const MarkerMap& map, std::span<const TagDetection> l, std::span<const TagDetection> r) const {
    return solve_marker_pose_stereo(map, left, right, extrinsics.R_right_from_left, extrinsics.t_right_from_left, l, r);
  }
};

// The camera's position error along its (true) optical axis, and across it.
double depth_error(const Pose& solved, const Pose& truth) {
  const Vec3 axis = truth.R_site_from_camera * Vec3::UnitZ();
  return std::abs((solved.t_site_from_camera - truth.t_site_from_camera).dot(axis));
}

// ---------------------------------------------------------------------------------------------
// The joint solve on exact and noisy corners.

TEST(StereoMarkerPose, ThePoseMovesBetweenTheCameras) {
  const StereoScene s;
  const Pose left = heads_at_three_metres()[1];
  const Pose right = right_camera_pose(left, s.extrinsics);
  const Vec3 site(0.3, 2.0, 1.1);
  const Vec3 in_left = left.R_site_from_camera.conjugate() * (site - left.t_site_from_camera);
  const Vec3 in_right = right.R_site_from_camera.conjugate() * (site - right.t_site_from_camera);
  EXPECT_LT((in_right - (s.extrinsics.R_right_from_left * in_left + s.extrinsics.t_right_from_left)).norm(), 1e-12);
  const Pose back = left_camera_pose(right, s.extrinsics);
  EXPECT_LT(position_error(back, left), 1e-12);
  EXPECT_LT(rotation_error_deg(back, left), 1e-9);
}

TEST(StereoMarkerPose, ExactCornersOfBothCamerasGiveTheLeftCamerasPose) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  std::mt19937 random(1);
  for (const Pose& truth : heads_at_three_metres()) {
    const auto l = corners_seen(map, s.left, truth, 0, random);
    const auto r = corners_seen(map, s.right, right_camera_pose(truth, s.extrinsics), 0, random);
    ASSERT_EQ(l.size(), 4u);
    ASSERT_EQ(r.size(), 4u);
    const MarkerSolve solve = s.solve(map, l, r);
    ASSERT_TRUE(solve.pose);
    EXPECT_LT(position_error(*solve.pose, truth), 1e-7);
    EXPECT_LT(rotation_error_deg(*solve.pose, truth), 1e-6);
    EXPECT_LT(solve.rms_px, 1e-5);
    EXPECT_EQ(solve.tags_used, (std::vector<int>{0, 1, 2, 3}));
    ASSERT_EQ(solve.residuals.size(), 8u);
    EXPECT_EQ(std::count_if(solve.residuals.begin(), solve.residuals.end(),
                            [](const TagResidual& t) { return t.camera == CameraSide::Right; }),
              4);
    EXPECT_EQ(solve.describe_flags(), "ok");
    EXPECT_LT(solve.ambiguity, 0.01);
  }
}

// σ 0.3 px of corner noise, heads 2 to 12 m from the wall of four, one seed: the joint solve's
// RMS depth error is under 0.8 of the left camera's alone, its position and rotation errors
// smaller too.
TEST(StereoMarkerPose, NoisyCornersOfBothCamerasBeatTheLeftCameraAlone) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  std::mt19937 random(22);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  double depth_left = 0, depth_both = 0, position_left = 0, position_both = 0, angle_left = 0, angle_both = 0;
  int n = 0;
  for (int i = 0; i < 60; ++i) {
    const double distance = 2.0 + 10.0 * (i + 0.5) / 60;
    const Pose truth = head(Vec3(0.2 * distance * uniform(random), 3.0 - distance, 1.6 + 0.2 * uniform(random)),
                            Vec3(0.3 * uniform(random), 3.0, 1.6 + 0.2 * uniform(random)), 8 * uniform(random));
    const auto l = corners_seen(map, s.left, truth, 0.3, random);
    const auto r = corners_seen(map, s.right, right_camera_pose(truth, s.extrinsics), 0.3, random);
    if (l.empty() || r.empty()) continue;
    const MarkerSolve left = solve_marker_pose(map, s.left, l);
    const MarkerSolve both = s.solve(map, l, r);
    ASSERT_TRUE(left.pose);
    ASSERT_TRUE(both.pose);
    ++n;
    depth_left += std::pow(depth_error(*left.pose, truth), 2);
    depth_both += std::pow(depth_error(*both.pose, truth), 2);
    position_left += std::pow(position_error(*left.pose, truth), 2);
    position_both += std::pow(position_error(*both.pose, truth), 2);
    angle_left += std::pow(rotation_error_deg(*left.pose, truth), 2);
    angle_both += std::pow(rotation_error_deg(*both.pose, truth), 2);
  }
  ASSERT_GE(n, 50);
  const auto rms = [n](double sum) { return std::sqrt(sum / n); };
  std::printf("%d heads, 2-12 m, σ 0.3 px: RMS depth error left %.1f mm, both %.1f mm (%.2f); position %.1f / %.1f mm; "
              "rotation %.3f / %.3f°\n",
              n, rms(depth_left) * 1e3, rms(depth_both) * 1e3, rms(depth_both) / rms(depth_left), rms(position_left) * 1e3,
              rms(position_both) * 1e3, rms(angle_left), rms(angle_both));
  EXPECT_LT(rms(depth_both), 0.8 * rms(depth_left));
  EXPECT_LT(rms(position_both), rms(position_left));
  EXPECT_LT(rms(angle_both), rms(angle_left));
}

TEST(StereoMarkerPose, TagsSeenByOneCameraOnly) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  const Pose truth = heads_at_three_metres()[2];
  std::mt19937 random(3);
  const auto l = corners_seen(map, s.left, truth, 0, random);
  const auto r = corners_seen(map, s.right, right_camera_pose(truth, s.extrinsics), 0, random);
  ASSERT_EQ(l.size(), 4u);
  ASSERT_EQ(r.size(), 4u);

  // The right camera alone: its own solve, moved to the left camera.
  MarkerSolve solve = s.solve(map, {}, r);
  ASSERT_TRUE(solve.pose);
  EXPECT_LT(position_error(*solve.pose, truth), 1e-7);
  EXPECT_LT(rotation_error_deg(*solve.pose, truth), 1e-6);
  ASSERT_EQ(solve.residuals.size(), 4u);
  for (const TagResidual& t : solve.residuals) EXPECT_EQ(t.camera, CameraSide::Right);
  EXPECT_FALSE(solve.no_tags);

  // The left camera alone.
  solve = s.solve(map, l, {});
  ASSERT_TRUE(solve.pose);
  EXPECT_LT(position_error(*solve.pose, truth), 1e-7);
  for (const TagResidual& t : solve.residuals) EXPECT_EQ(t.camera, CameraSide::Left);

  // One tag in each camera, a different one: neither camera alone has more than one tag, the
  // two together pin the pose as two tags do.
  const std::vector<TagDetection> only_0{l[0]};
  const std::vector<TagDetection> only_3{r[3]};
  solve = s.solve(map, only_0, only_3);
  ASSERT_TRUE(solve.pose);
  EXPECT_LT(position_error(*solve.pose, truth), 1e-6);
  EXPECT_LT(rotation_error_deg(*solve.pose, truth), 1e-5);
  EXPECT_EQ(solve.tags_used, (std::vector<int>{0, 3}));
  ASSERT_EQ(solve.residuals.size(), 2u);
  EXPECT_EQ(solve.residuals[0].camera, CameraSide::Left);
  EXPECT_EQ(solve.residuals[1].camera, CameraSide::Right);
  EXPECT_LT(solve.ambiguity, 0.01);

  solve = s.solve(map, {}, {});
  EXPECT_FALSE(solve.pose);
  EXPECT_TRUE(solve.no_tags);
}

// A single tag, 2 to 8 m away: one camera's two planar solutions fit almost equally and it often
// keeps the wrong one; the second view, 64 mm aside, picks the right one more often. (The
// ambiguity ratio itself does not fall: the best fit's RMS rises towards the noise as the
// corners outnumber the six unknowns, docs/tracking.md.)
TEST(StereoMarkerPose, ASecondViewOfASingleTagPicksTheRightSolutionMoreOften) {
  const StereoScene s;
  MarkerMap map;
  map.tags = {wall_tag(5, 0.0, 1.6)};
  std::mt19937 random(5);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int wrong_left = 0, wrong_both = 0, ambiguous_left = 0, ambiguous_both = 0, n = 0;
  double depth_left = 0, depth_both = 0;
  for (int i = 0; i < 200; ++i) {
    const double distance = 2.0 + 6.0 * (i + 0.5) / 200;
    const Pose truth = head(Vec3(0.25 * distance * uniform(random), 3.0 - distance, 1.6 + 0.2 * uniform(random)),
                            Vec3(0.3 * uniform(random), 3.0, 1.6 + 0.2 * uniform(random)), 8 * uniform(random));
    const auto l = corners_seen(map, s.left, truth, 0.3, random);
    const auto r = corners_seen(map, s.right, right_camera_pose(truth, s.extrinsics), 0.3, random);
    if (l.empty() || r.empty()) continue;
    const MarkerSolve left = solve_marker_pose(map, s.left, l);
    const MarkerSolve both = s.solve(map, l, r);
    ASSERT_TRUE(left.pose);
    ASSERT_TRUE(both.pose);
    ++n;
    wrong_left += rotation_error_deg(*left.pose, truth) > 5 ? 1 : 0;
    wrong_both += rotation_error_deg(*both.pose, truth) > 5 ? 1 : 0;
    ambiguous_left += left.ambiguous ? 1 : 0;
    ambiguous_both += both.ambiguous ? 1 : 0;
    depth_left += std::pow(depth_error(*left.pose, truth), 2);
    depth_both += std::pow(depth_error(*both.pose, truth), 2);
  }
  ASSERT_GE(n, 150);
  std::printf("single 20 cm tag, 2-8 m, σ 0.3 px, %d heads: rotation off by more than 5° left %d, both %d; flagged "
              "ambiguous %d, %d; RMS depth error %.0f, %.0f mm\n",
              n, wrong_left, wrong_both, ambiguous_left, ambiguous_both, std::sqrt(depth_left / n) * 1e3,
              std::sqrt(depth_both / n) * 1e3);
  EXPECT_LT(wrong_both, 0.9 * wrong_left);
  EXPECT_LT(depth_both, depth_left);
}

TEST(StereoMarkerPose, AMovedTagIsRejectedInBothCameras) {
  const StereoScene s;
  const MarkerMap truth_map = wall_of_four();
  MarkerMap stale = truth_map;
  stale.tags[3].t_site_from_tag += Vec3(0.15, 0.0, -0.10);
  const Pose truth = heads_at_three_metres()[0];
  std::mt19937 random(7);
  const auto l = corners_seen(truth_map, s.left, truth, 0, random);
  const auto r = corners_seen(truth_map, s.right, right_camera_pose(truth, s.extrinsics), 0, random);
  const MarkerSolve solve = s.solve(stale, l, r);
  ASSERT_TRUE(solve.pose);
  EXPECT_EQ(solve.tags_used, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(solve.tags_rejected, (std::vector<int>{3}));
  ASSERT_EQ(solve.residuals.size(), 8u);
  for (std::size_t i = 6; i < 8; ++i) {
    EXPECT_EQ(solve.residuals[i].id, 3);
    EXPECT_GT(solve.residuals[i].rms_px, 20.0);
  }
  EXPECT_LT(position_error(*solve.pose, truth), 1e-6);
  EXPECT_FALSE(solve.high_error);
}

TEST(StereoMarkerPose, ExtrinsicsThatAreNoRotationAreRefused) {
  const StereoScene s;
  Eigen::Matrix3d not_a_rotation = Eigen::Matrix3d::Identity();
  not_a_rotation(0, 0) = 1.1;
  EXPECT_THROW(solve_marker_pose_stereo(wall_of_four(), s.left, s.right, not_a_rotation, Vec3(-0.064, 0, 0), {}, {}),
               std::invalid_argument);
  MarkerPoseOptions bad;
  bad.outlier_px = 0;
  EXPECT_THROW(solve_marker_pose_stereo(wall_of_four(), s.left, s.right, Eigen::Matrix3d::Identity(), Vec3(-0.064, 0, 0),
                                        {}, {}, bad),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// The stereo tracker on rendered pairs.

struct RenderedPair {
  cv::Mat left, right;
};

RenderedPair render_pair(const StereoScene& s, const MarkerMap& map, const Pose& truth, std::uint64_t seed) {
  MarkerRenderOptions options;
  options.seed = seed;
  RenderedPair pair;
  pair.left = render_markers(map, s.left, truth, options);
  options.seed = seed + 1000;
  pair.right = render_markers(map, s.right, right_camera_pose(truth, s.extrinsics), options);
  return pair;
}

TEST(StereoMarkerTracker, BothCamerasEndToEnd) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  MarkerTracker tracker(map, s.calibration);
  EXPECT_TRUE(tracker.stereo());
  EXPECT_NE(tracker.describe().find("stereo camera, both cameras"), std::string::npos) << tracker.describe();
  std::uint64_t seed = 1;
  for (const Pose& truth : heads_at_three_metres()) {
    const RenderedPair pair = render_pair(s, map, truth, seed++);
    const MarkerSolve solve = tracker.process(pair.left, pair.right, 4.0);
    ASSERT_TRUE(solve.pose);
    std::printf("stereo tracker at 3 m: position error %.2f mm, rotation error %.3f°, RMS %.3f px over %zu views\n",
                position_error(*solve.pose, truth) * 1e3, rotation_error_deg(*solve.pose, truth), solve.rms_px,
                solve.residuals.size());
    EXPECT_EQ(solve.residuals.size(), 8u);
    EXPECT_LE(position_error(*solve.pose, truth), 0.01);
    EXPECT_LE(rotation_error_deg(*solve.pose, truth), 0.5);
    EXPECT_EQ(solve.describe_flags(), "ok");
    const std::optional<Pose> now = tracker.pose_at(4.1);
    ASSERT_TRUE(now);
    EXPECT_LE(position_error(*now, truth), 0.01);
  }
  EXPECT_NE(tracker.describe().find("the last 4 tags"), std::string::npos) << tracker.describe();

  // The live camera thread hands over the halves of one side-by-side frame: views, not copies.
  const Pose truth = heads_at_three_metres()[0];
  const RenderedPair pair = render_pair(s, map, truth, 77);
  cv::Mat side_by_side;
  cv::hconcat(pair.left, pair.right, side_by_side);
  const MarkerSolve solve = tracker.process(side_by_side.colRange(0, 1280), side_by_side.colRange(1280, 2560), 5.0);
  ASSERT_TRUE(solve.pose);
  EXPECT_LE(position_error(*solve.pose, truth), 0.01);
  EXPECT_EQ(solve.residuals.size(), 8u);
}

TEST(StereoMarkerTracker, TheRightCameraOnlySetting) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  MarkerTrackerOptions options;
  options.stereo_cameras = StereoCameras::Right;
  MarkerTracker tracker(map, s.calibration, options);
  EXPECT_NE(tracker.describe().find("the right camera only"), std::string::npos) << tracker.describe();
  const Pose truth = heads_at_three_metres()[1];
  const RenderedPair pair = render_pair(s, map, truth, 31);
  const MarkerSolve solve = tracker.process(pair.left, pair.right, 1.0);
  ASSERT_TRUE(solve.pose);
  EXPECT_LE(position_error(*solve.pose, truth), 0.01) << "the left camera's pose, from the right camera";
  EXPECT_LE(rotation_error_deg(*solve.pose, truth), 0.5);
  ASSERT_EQ(solve.residuals.size(), 4u);
  for (const TagResidual& t : solve.residuals) EXPECT_EQ(t.camera, CameraSide::Right);

  // The left frame is not looked at: tags only there are not seen.
  const cv::Mat blank(720, 1280, CV_8UC1, cv::Scalar(110));
  EXPECT_TRUE(tracker.process(pair.left, blank, 2.0).no_tags);
  options.stereo_cameras = StereoCameras::Left;
  MarkerTracker left_only(map, s.calibration, options);
  EXPECT_NE(left_only.describe().find("the left camera only"), std::string::npos);
  EXPECT_TRUE(left_only.process(blank, pair.right, 2.0).no_tags);
  const MarkerSolve from_left = left_only.process(pair.left, blank, 2.0);
  ASSERT_TRUE(from_left.pose);
  EXPECT_LE(position_error(*from_left.pose, truth), 0.01);
}

TEST(StereoMarkerTracker, BadInputsAreNamed) {
  const StereoScene s;
  const MarkerMap map = wall_of_four();
  MarkerTracker tracker(map, s.calibration);
  const cv::Mat frame(720, 1280, CV_8UC1, cv::Scalar(110));
  try {
    tracker.process(frame, cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), 1.0);
    FAIL() << "a 640×480 right frame was accepted by a 1280×720 calibration";
  } catch (const skylit::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("hmd_stereo.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("right.image_width"), std::string::npos) << message;
    EXPECT_NE(message.find("640×480"), std::string::npos) << message;
  }
  EXPECT_THROW(tracker.process(cv::Mat(720, 1279, CV_8UC1), frame, 1.0), skylit::InputError);
  EXPECT_THROW(tracker.process(frame, 1.0), std::logic_error) << "a stereo tracker takes both frames";
  MarkerTracker single(map, hmd_camera());
  EXPECT_FALSE(single.stereo());
  EXPECT_THROW(single.process(frame, frame, 1.0), std::logic_error);

  StereoCalibration no_baseline = stereo_camera();
  no_baseline.t_right_from_left = Vec3::Zero();
  try {
    MarkerTracker refused(map, no_baseline);
    FAIL() << "a stereo calibration without a baseline was accepted";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("hmd_stereo.yaml"), std::string::npos) << e.what();
  }
}

TEST(StereoMarkerTracker, TheConfigChoosesTheCameras) {
  skylit::test::TempDir dir("skylit_stereo_tracking_");
  save_marker_map(wall_of_four(), dir.path() / "tags.yaml");
  const auto file = dir.write("live.yaml", "pose:\n  kind: markers\n  map: tags.yaml\n  cameras: right\n");
  const PoseConfig config = load_pose_config(file);
  EXPECT_EQ(config.markers.stereo_cameras, StereoCameras::Right);
  const auto tracker = open_stereo_marker_tracker(config, stereo_camera());
  EXPECT_TRUE(tracker->stereo());
  EXPECT_NE(tracker->describe().find("the right camera only"), std::string::npos) << tracker->describe();
  EXPECT_EQ(load_pose_config(dir.write("default.yaml", "pose:\n  kind: markers\n  map: tags.yaml\n")).markers.stereo_cameras,
            StereoCameras::Both);
  try {
    load_pose_config(dir.write("bad.yaml", "pose:\n  kind: markers\n  map: tags.yaml\n  cameras: middle\n"));
    FAIL() << "cameras: middle was accepted";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'pose.cameras'"), std::string::npos) << e.what();
  }
}

}  // namespace stereo_tracking_test
