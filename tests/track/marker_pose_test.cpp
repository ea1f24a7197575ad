// Head pose from tags: exact corners (the solver alone), then rendered frames through the
// detector (the cases of docs/tracking.md), the tracker as a pose source, and its config.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "../support/temp_dir.hpp"
#include <opencv2/imgproc.hpp>

#include "marker_scene.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/marker_tracker.hpp"
#include "skylit/track/tag_detector.hpp"
#include "skylit/camera/lens.hpp"

namespace marker_pose_test {  // named, not anonymous: the test program is one unity build

using namespace skylit::track;
using namespace marker_scene;
namespace fs = std::filesystem;

// The corners of the map's tags as a perfect detector would report them, plus noise (pixels).
std::vector<TagDetection> exact_detections(const MarkerMap& map, const skylit::camera::Lens& lens, const Pose& camera,
                                           double noise_px = 0, unsigned seed = 1) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, noise_px > 0 ? noise_px : 1.0);
  std::vector<TagDetection> detections;
  for (const MarkerTag& tag : map.tags) {
    TagDetection d;
    d.id = tag.id;
    const auto corners = tag_corners_in_site(tag);
    for (std::size_t k = 0; k < 4; ++k) {
      const Vec3 p = camera.R_site_from_camera.conjugate() * (corners[k] - camera.t_site_from_camera);
      d.corners[k] = *lens.project(p);
      if (noise_px > 0) d.corners[k] += Eigen::Vector2d(noise(random), noise(random));
    }
    detections.push_back(d);
  }
  return detections;
}

struct Errors {
  double position_m = 0;
  double rotation_deg = 0;
};

Errors errors_of(const MarkerSolve& solve, const Pose& truth) {
  return {position_error(*solve.pose, truth), rotation_error_deg(*solve.pose, truth)};
}

// ---------------------------------------------------------------------------------------------
// The solver on exact corners.

TEST(MarkerPose, ExactCornersOfFourTagsGiveThePose) {
  const skylit::camera::Lens lens(hmd_camera());
  const MarkerMap map = wall_of_four();
  for (const Pose& truth : heads_at_three_metres()) {
    const auto detections = exact_detections(map, lens, truth);
    const MarkerSolve solve = solve_marker_pose(map, lens, detections);
    ASSERT_TRUE(solve.pose);
    const Errors e = errors_of(solve, truth);
    EXPECT_LT(e.position_m, 1e-7);
    EXPECT_LT(e.rotation_deg, 1e-6);
    EXPECT_LT(solve.rms_px, 1e-5);
    EXPECT_EQ(solve.tags_used.size(), 4u);
    EXPECT_TRUE(solve.tags_rejected.empty());
    EXPECT_EQ(solve.describe_flags(), "ok");
    EXPECT_LT(solve.ambiguity, 0.01);
  }
}

TEST(MarkerPose, ASingleTagReportsBothSolutionsAndTheirAmbiguity) {
  const skylit::camera::Lens lens(hmd_camera());
  MarkerMap map;
  map.tags = {wall_tag(5, 0.0, 1.6)};
  // Close (1.2 m) and seen 30° from the side: the two planar solutions differ clearly.
  const Pose close = head(Vec3(0.9, 1.45, 1.6), Vec3(0.0, 3.0, 1.6), 3);
  MarkerSolve solve = solve_marker_pose(map, lens, exact_detections(map, lens, close));
  ASSERT_TRUE(solve.pose);
  EXPECT_LT(errors_of(solve, close).position_m, 1e-6);
  ASSERT_TRUE(solve.alternative) << "IPPE's second solution is reported";
  EXPECT_GT(rotation_error_deg(*solve.alternative, close), 1.0);
  EXPECT_GT(solve.alternative_rms_px, 1.0);
  EXPECT_LT(solve.ambiguity, 0.01);
  EXPECT_FALSE(solve.ambiguous);
  EXPECT_FALSE(solve.single_distant_tag);

  // Far (8 m, ~25 px) and almost head-on with 0.3 px of corner noise: both solutions fit.
  const Pose far = head(Vec3(0.3, -5.0, 1.6), Vec3(0.0, 3.0, 1.6));
  int flagged = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    solve = solve_marker_pose(map, lens, exact_detections(map, lens, far, 0.3, seed));
    ASSERT_TRUE(solve.pose);
    EXPECT_TRUE(solve.single_distant_tag);
    flagged += solve.ambiguous ? 1 : 0;
    std::printf("far single tag, seed %u: ambiguity %.2f, position error %.3f m, rotation error %.2f°\n", seed,
                solve.ambiguity, position_error(*solve.pose, far), rotation_error_deg(*solve.pose, far));
  }
  EXPECT_GE(flagged, 1) << "a distant head-on tag is ambiguous under noise";
}

TEST(MarkerPose, FisheyeCornersAreUndistortedFirst) {
  skylit::camera::CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = skylit::camera::LensModel::Fisheye;
  c.fx = c.fy = 450;  // equidistant-ish: 160° across the width
  c.cx = 639.5;
  c.cy = 359.5;
  c.D = {0.02, -0.01, 0.002, 0.0};
  const skylit::camera::Lens lens(c);
  const MarkerMap map = wall_of_four();
  const Pose truth = head(Vec3(1.5, 1.0, 1.2), Vec3(3.0, 3.0, 2.5), 5);  // tags far off the axis
  const MarkerSolve solve = solve_marker_pose(map, lens, exact_detections(map, lens, truth));
  ASSERT_TRUE(solve.pose);
  EXPECT_LT(errors_of(solve, truth).position_m, 1e-7);
  EXPECT_LT(solve.rms_px, 1e-5);
}

TEST(MarkerPose, NothingToSolveIsFlaggedNotThrown) {
  const skylit::camera::Lens lens(hmd_camera());
  const MarkerMap map = wall_of_four();
  MarkerSolve solve = solve_marker_pose(map, lens, {});
  EXPECT_FALSE(solve.pose);
  EXPECT_TRUE(solve.no_tags);
  EXPECT_EQ(solve.describe_flags(), "no tags");

  auto detections = exact_detections(map, lens, heads_at_three_metres()[0]);
  for (auto& d : detections) d.id += 100;  // none of them in the map
  solve = solve_marker_pose(map, lens, detections);
  EXPECT_TRUE(solve.no_tags);
  EXPECT_EQ(solve.tags_unknown, (std::vector<int>{100, 101, 102, 103}));

  // The same id twice: neither can be trusted.
  detections = exact_detections(map, lens, heads_at_three_metres()[0]);
  detections[1].id = 0;
  solve = solve_marker_pose(map, lens, detections);
  ASSERT_TRUE(solve.pose);
  EXPECT_EQ(solve.tags_used, (std::vector<int>{2, 3}));
  EXPECT_EQ(solve.tags_rejected, (std::vector<int>{0}));

  // A collapsed quad gives no start and no crash.
  detections = exact_detections(map, lens, heads_at_three_metres()[0]);
  detections.resize(1);
  for (auto& corner : detections[0].corners) corner = Eigen::Vector2d(600, 300);
  solve = solve_marker_pose(map, lens, detections);
  EXPECT_FALSE(solve.pose && !solve.high_error);

  MarkerPoseOptions bad;
  bad.max_ambiguity = 2;
  EXPECT_THROW(solve_marker_pose(map, lens, {}, bad), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Rendered frames through the detector.

struct Rendered {
  skylit::camera::Lens lens{hmd_camera()};
  TagDetector detector;

  MarkerSolve solve(const MarkerMap& truth_map, const MarkerMap& solve_map, const Pose& camera,
                    const MarkerRenderOptions& render = {}, double blur_sigma = 0) {
    cv::Mat frame = render_markers(truth_map, lens, camera, render);
    if (blur_sigma > 0) cv::GaussianBlur(frame, frame, cv::Size(), blur_sigma);
    return solve_marker_pose(solve_map, lens, detector.detect(frame));
  }
};

TEST(MarkerPoseRendered, FourTagsAtThreeMetresWithinOneCentimetreAndHalfADegree) {
  Rendered r;
  const MarkerMap map = wall_of_four();
  unsigned seed = 1;
  for (const Pose& truth : heads_at_three_metres()) {
    MarkerRenderOptions render;
    render.seed = seed++;
    const MarkerSolve solve = r.solve(map, map, truth, render);
    ASSERT_TRUE(solve.pose);
    const Errors e = errors_of(solve, truth);
    std::printf("4 tags at 3 m: position error %.2f mm, rotation error %.3f°, RMS %.3f px\n", e.position_m * 1e3,
                e.rotation_deg, solve.rms_px);
    EXPECT_EQ(solve.tags_used.size(), 4u);
    EXPECT_LE(e.position_m, 0.01);
    EXPECT_LE(e.rotation_deg, 0.5);
    EXPECT_LT(solve.rms_px, 0.5);
    EXPECT_EQ(solve.describe_flags(), "ok");
  }
}

TEST(MarkerPoseRendered, SeveralTagsTogetherBeatOne) {
  Rendered r;
  const MarkerMap four = wall_of_four();
  MarkerMap one;
  one.tags = {four.tags[1]};
  double error_four = 0, error_one = 0, angle_four = 0, angle_one = 0;
  unsigned seed = 11;
  for (const Pose& truth : heads_at_three_metres()) {
    MarkerRenderOptions render;
    render.seed = seed++;
    const MarkerSolve with_four = r.solve(four, four, truth, render);
    const MarkerSolve with_one = r.solve(one, one, truth, render);
    ASSERT_TRUE(with_four.pose);
    ASSERT_TRUE(with_one.pose);
    std::printf("one tag at 3 m: %s, ambiguity %.2f, %.1f px edge, errors %.1f mm %.2f°\n", with_one.describe_flags().c_str(),
                with_one.ambiguity, with_one.residuals[0].edge_px, position_error(*with_one.pose, truth) * 1e3,
                rotation_error_deg(*with_one.pose, truth));
    error_four += position_error(*with_four.pose, truth) / 3;
    error_one += position_error(*with_one.pose, truth) / 3;
    angle_four += rotation_error_deg(*with_four.pose, truth) / 3;
    angle_one += rotation_error_deg(*with_one.pose, truth) / 3;
  }
  std::printf("mean errors at 3 m: four tags %.2f mm %.3f°, one tag %.2f mm %.3f°\n", error_four * 1e3, angle_four,
              error_one * 1e3, angle_one);
  EXPECT_LT(error_four, error_one);
  EXPECT_LT(angle_four, angle_one);
}

TEST(MarkerPoseRendered, ABlurredFrameStillGivesAPose) {
  Rendered r;
  const MarkerMap map = wall_of_four();
  const Pose truth = heads_at_three_metres()[1];
  const MarkerSolve solve = r.solve(map, map, truth, {}, 2.5);
  ASSERT_TRUE(solve.pose);
  const Errors e = errors_of(solve, truth);
  std::printf("blurred (σ = 2.5 px): %zu tags, position error %.2f mm, rotation error %.3f°, RMS %.3f px\n",
              solve.tags_used.size(), e.position_m * 1e3, e.rotation_deg, solve.rms_px);
  EXPECT_EQ(solve.tags_used.size(), 4u);
  EXPECT_LE(e.position_m, 0.02);
  EXPECT_LE(e.rotation_deg, 1.0);
  EXPECT_FALSE(solve.high_error);
}

TEST(MarkerPoseRendered, AMovedTagIsRejectedAsAnOutlier) {
  Rendered r;
  const MarkerMap truth_map = wall_of_four();
  MarkerMap stale = truth_map;
  stale.tags[3].t_site_from_tag += Vec3(0.15, 0.0, -0.10);  // moved since the map was made
  const Pose truth = heads_at_three_metres()[0];
  const MarkerSolve solve = r.solve(truth_map, stale, truth);
  ASSERT_TRUE(solve.pose);
  EXPECT_EQ(solve.tags_rejected, (std::vector<int>{3}));
  EXPECT_EQ(solve.tags_used, (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(solve.residuals.size(), 4u);
  EXPECT_EQ(solve.residuals.back().id, 3);
  EXPECT_GT(solve.residuals.back().rms_px, 20.0) << "the moved tag's error is reported";
  const Errors e = errors_of(solve, truth);
  EXPECT_LE(e.position_m, 0.01);
  EXPECT_LE(e.rotation_deg, 0.5);
  EXPECT_FALSE(solve.high_error);
}

TEST(MarkerPoseRendered, ASingleDistantTagIsFlagged) {
  Rendered r;
  MarkerMap map;
  map.tags = {wall_tag(9, 0.0, 1.6)};
  const Pose truth = head(Vec3(0.2, -4.0, 1.6), Vec3(0.0, 3.0, 1.6), 2);  // 7 m: the tag ~28 px
  const MarkerSolve solve = r.solve(map, map, truth);
  ASSERT_TRUE(solve.pose) << "still detected at decimation 2";
  EXPECT_TRUE(solve.single_distant_tag);
  ASSERT_EQ(solve.residuals.size(), 1u);
  EXPECT_LT(solve.residuals[0].edge_px, 40);
  std::printf("single tag at 7 m: %s, ambiguity %.2f, position error %.1f mm, rotation error %.2f°\n",
              solve.describe_flags().c_str(), solve.ambiguity, position_error(*solve.pose, truth) * 1e3,
              rotation_error_deg(*solve.pose, truth));

  // The tracker treats it as lost unless told to accept it.
  const cv::Mat frame = render_markers(map, r.lens, truth);
  MarkerTracker strict(map, hmd_camera());
  strict.process(frame, 2.0);
  EXPECT_FALSE(strict.pose_at(2.0));
  MarkerTrackerOptions lenient;
  lenient.accept_single_distant = true;
  lenient.accept_ambiguous = true;
  MarkerTracker tolerant(map, hmd_camera(), lenient);
  tolerant.process(frame, 2.0);
  EXPECT_TRUE(tolerant.pose_at(2.0));
}

// ---------------------------------------------------------------------------------------------
// The tracker as a pose source.

TEST(MarkerTracker, AnswersWithTheLatestAcceptedPoseWhileItIsFresh) {
  const MarkerMap map = wall_of_four();
  const skylit::camera::Lens lens(hmd_camera());
  MarkerTrackerOptions options;
  options.max_age = 0.2;
  MarkerTracker tracker(map, hmd_camera(), options);
  EXPECT_FALSE(tracker.pose_at(0.0));
  EXPECT_NE(tracker.describe().find("no frame yet"), std::string::npos);

  const Pose truth = heads_at_three_metres()[2];
  const MarkerSolve solve = tracker.process(render_markers(map, lens, truth), 10.0);
  ASSERT_TRUE(solve.pose);
  EXPECT_DOUBLE_EQ(solve.pose->timestamp, 10.0);
  const std::optional<Pose> now = tracker.pose_at(10.1);
  ASSERT_TRUE(now);
  EXPECT_DOUBLE_EQ(now->timestamp, 10.1);
  EXPECT_LE(position_error(*now, truth), 0.01);
  EXPECT_FALSE(tracker.pose_at(10.3)) << "older than max_age: lost";
  EXPECT_NE(tracker.describe().find("4 tags"), std::string::npos) << tracker.describe();

  // A frame without tags: the last pose stays until it is too old.
  const cv::Mat blank(720, 1280, CV_8UC1, cv::Scalar(110));
  const MarkerSolve none = tracker.process(blank, 10.05);
  EXPECT_TRUE(none.no_tags);
  EXPECT_TRUE(tracker.pose_at(10.1));
  ASSERT_TRUE(tracker.latest_solve());
  EXPECT_TRUE(tracker.latest_solve()->no_tags);

  // Frames of another size than the calibration's.
  try {
    tracker.process(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), 11.0);
    FAIL() << "a 640×480 frame was accepted by a 1280×720 calibration";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("640×480"), std::string::npos) << e.what();
  }
}

TEST(MarkerTracker, TagsOfAnotherFamilyAreNotSeen) {
  MarkerMap printed = wall_of_four();
  MarkerMap configured = printed;
  configured.family = "tag25h9";  // the map says 25h9, the site has 36h11
  const skylit::camera::Lens lens(hmd_camera());
  MarkerTracker tracker(configured, hmd_camera());
  const MarkerSolve solve = tracker.process(render_markers(printed, lens, heads_at_three_metres()[0]), 1.0);
  EXPECT_TRUE(solve.no_tags);
  EXPECT_FALSE(solve.pose);
  EXPECT_FALSE(tracker.pose_at(1.0));
}

// ---------------------------------------------------------------------------------------------
// The `pose: {kind: markers}` config.

TEST(MarkerConfig, ReadsTheMapTheCalibrationAndTheKnobs) {
  skylit::test::TempDir dir("skylit_marker_config_");
  save_marker_map(wall_of_four(), dir.path() / "tags.yaml");
  skylit::camera::save_calibration(hmd_camera(), dir.path() / "hmd.yaml");
  const fs::path file = dir.write("live.yaml",
                                  "pose:\n"
                                  "  kind: markers\n"
                                  "  map: tags.yaml\n"
                                  "  calibration: hmd.yaml\n"
                                  "  decimation: 1.5\n"
                                  "  blur: 0.8\n"
                                  "  threads: 2\n"
                                  "  outlier_px: 3\n"
                                  "  max_age: 0.25\n"
                                  "  accept_ambiguous: true\n");
  const PoseConfig config = load_pose_config(file);
  EXPECT_EQ(config.kind, PoseConfig::Kind::Markers);
  EXPECT_EQ(config.marker_map, dir.path() / "tags.yaml");
  EXPECT_EQ(config.marker_calibration, dir.path() / "hmd.yaml");
  EXPECT_DOUBLE_EQ(config.markers.detector.decimation, 1.5);
  EXPECT_DOUBLE_EQ(config.markers.detector.blur_sigma, 0.8);
  EXPECT_EQ(config.markers.detector.threads, 2);
  EXPECT_TRUE(config.markers.detector.refine_edges) << "defaults stay";
  EXPECT_DOUBLE_EQ(config.markers.pose.outlier_px, 3);
  EXPECT_DOUBLE_EQ(config.markers.max_age, 0.25);
  EXPECT_TRUE(config.markers.accept_ambiguous);

  const auto tracker = open_marker_tracker(config);
  EXPECT_EQ(tracker->map().tags.size(), 4u);
  EXPECT_NE(tracker->describe().find("tags.yaml"), std::string::npos);
  // Until the live service feeds it frames, the generic opener refuses the kind plainly.
  try {
    open_pose_source(config);
    FAIL() << "open_pose_source accepted kind markers";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("field 'pose.kind'"), std::string::npos) << e.what();
  }

  const fs::path bad = dir.write("bad.yaml", "pose:\n  kind: markers\n  map: tags.yaml\n  decimaton: 2\n");
  try {
    load_pose_config(bad);
    FAIL() << "an unknown key was accepted";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml:4:3: field 'pose.decimaton': unknown field. Fix: did you mean 'decimation'?"),
              std::string::npos)
        << e.what();
  }
  const fs::path range = dir.write("range.yaml", "pose:\n  kind: markers\n  map: tags.yaml\n  decimation: 0.5\n");
  try {
    load_pose_config(range);
    FAIL() << "decimation 0.5 was accepted";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("range.yaml:4:15: field 'pose.decimation': 0.5 is outside 1..16"), std::string::npos)
        << e.what();
  }
}

}  // namespace
