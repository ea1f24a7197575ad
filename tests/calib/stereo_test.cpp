// Stereo calibration: the real left/right pairs of data/chessboard against OpenCV's own
// stereoCalibrate (pinhole and fisheye); synthetic pairs through two known lenses at a known
// relative pose; pairs with the board in one photo only listed and not used; the stereo YAML's
// round trip and its errors.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/calib/board.hpp"
#include "skylit/calib/stereo.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "synthetic_board.hpp"

namespace stereo_calib_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using skylit::calib::BoardDetector;
using skylit::calib::BoardSpec;
using skylit::calib::PhotoPair;
using skylit::calib::StereoOptions;
using skylit::calib::StereoPhotos;
using skylit::calib::StereoResult;
using skylit::camera::CameraCalibration;
using skylit::camera::LensModel;
using skylit::camera::StereoCalibration;

constexpr double kStereoDeg = std::numbers::pi / 180.0;
const fs::path kPairs = fs::path(SKYLIT_SOURCE_DIR) / "data" / "chessboard";

BoardSpec sample_board() {
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.025;
  return spec;
}

// left01.jpg … left14.jpg and right01.jpg … right14.jpg (no 10), in pairs.
std::vector<fs::path> sample_photos(const std::string& side) {
  std::vector<fs::path> photos;
  for (const auto& entry : fs::directory_iterator(kPairs)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".jpg" && name.starts_with(side)) photos.push_back(entry.path());
  }
  std::sort(photos.begin(), photos.end());
  return photos;
}

double rotation_difference_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() / kStereoDeg;
}

cv::Mat camera_matrix_of(const CameraCalibration& c) { return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1); }

struct OpenCVStereo {
  Eigen::Matrix3d R;
  Eigen::Vector3d T;
  double rms = 0;
};

// cv::stereoCalibrate on the corners of the pairs the result used, from the result's intrinsics:
// fixed (the same problem as ours), or free (OpenCV refines them too).
OpenCVStereo opencv_stereo(const StereoResult& result, const StereoPhotos& photos, bool fix_intrinsics) {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left, right;
  for (const skylit::calib::UsedPair& used : result.used) {
    const PhotoPair& pair = photos.pairs[used.index];
    object.push_back(pair.left->object);
    left.push_back(pair.left->image);
    right.push_back(pair.right->image);
  }
  const CameraCalibration& l = result.calibration.left;
  const CameraCalibration& r = result.calibration.right;
  cv::Mat K1 = camera_matrix_of(l), K2 = camera_matrix_of(r), D1(l.D, true), D2(r.D, true), R, T, E, F;
  const int flags = fix_intrinsics ? cv::CALIB_FIX_INTRINSIC : cv::CALIB_USE_INTRINSIC_GUESS;
  OpenCVStereo out;
  out.rms = cv::stereoCalibrate(object, left, right, K1, D1, K2, D2, cv::Size(l.image_width, l.image_height), R, T, E, F, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.R(i, j) = R.at<double>(i, j);
    out.T(i) = T.at<double>(i);
  }
  return out;
}

// The real pairs (OpenCV's stereo sample set: a 640×480 webcam pair, 9x6 board): our relative
// pose against OpenCV's stereoCalibrate on the same corners with the same intrinsics.
TEST(CalibStereo, RealPairsAgreeWithOpenCVStereoCalibrate) {
  const BoardDetector detector(sample_board());
  const std::vector<fs::path> left = sample_photos("left"), right = sample_photos("right");
  ASSERT_EQ(left.size(), 13u);
  ASSERT_EQ(right.size(), 13u);
  const StereoPhotos photos = skylit::calib::detect_stereo_boards(left, right, detector);
  const StereoResult result = skylit::calib::calibrate_stereo(photos, StereoOptions{});
  EXPECT_EQ(result.used.size(), 13u);
  EXPECT_TRUE(result.rejected.empty());
  const StereoCalibration& s = result.calibration;

  const OpenCVStereo fixed = opencv_stereo(result, photos, true);
  const double baseline_difference = std::abs(s.baseline_m() - fixed.T.norm()) / fixed.T.norm();
  const double rotation_difference = rotation_difference_deg(s.R_right_from_left, fixed.R);
  EXPECT_LT(baseline_difference, 0.01);        // the tolerance: 1%
  EXPECT_LT(rotation_difference, 0.2);         // and 0.2°
  EXPECT_LT((s.t_right_from_left - fixed.T).norm(), 0.01 * fixed.T.norm());
  EXPECT_NEAR(*s.rms, fixed.rms, 0.02 * fixed.rms);
  // The cameras of the set: about 83 mm apart, nearly parallel.
  EXPECT_NEAR(s.baseline_m(), 0.083, 0.005);
  EXPECT_LT(*s.rms, 0.5);
  EXPECT_LT(result.rectified_row_error_px, 0.3);
  EXPECT_LT(result.rectified_row_error_p95_px, 0.6);

  const OpenCVStereo unfixed = opencv_stereo(result, photos, false);
  std::printf("real pairs: baseline %.3f mm, RMS %.4f px, rows %.3f px (mean) %.3f px (95%%); stereoCalibrate with our intrinsics: "
              "baseline %.3f mm (difference %.2g%%), rotation difference %.2g°, RMS %.4f px; with free intrinsics: baseline "
              "%.3f mm (%.3f%%), rotation difference %.4f°, RMS %.4f px\n",
              1000 * s.baseline_m(), *s.rms, result.rectified_row_error_px, result.rectified_row_error_p95_px, 1000 * fixed.T.norm(),
              100 * baseline_difference, rotation_difference, fixed.rms, 1000 * unfixed.T.norm(),
              100 * std::abs(s.baseline_m() - unfixed.T.norm()) / unfixed.T.norm(), rotation_difference_deg(s.R_right_from_left, unfixed.R),
              unfixed.rms);
}

// The same pairs through OpenCV's fisheye model in both cameras, against cv::fisheye::stereoCalibrate.
TEST(CalibStereo, RealPairsFisheyeAgreeWithOpenCVFisheyeStereoCalibrate) {
  const BoardDetector detector(sample_board());
  const std::vector<fs::path> left = sample_photos("left"), right = sample_photos("right");
  const StereoPhotos photos = skylit::calib::detect_stereo_boards(left, right, detector);
  StereoOptions options;
  options.left.model = options.right.model = LensModel::Fisheye;
  const StereoResult result = skylit::calib::calibrate_stereo(photos, options);
  const StereoCalibration& s = result.calibration;
  ASSERT_GE(result.used.size(), 10u);
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left_corners, right_corners;
  for (const skylit::calib::UsedPair& used : result.used) {
    object.push_back(photos.pairs[used.index].left->object);
    left_corners.push_back(photos.pairs[used.index].left->image);
    right_corners.push_back(photos.pairs[used.index].right->image);
  }
  cv::Mat K1 = camera_matrix_of(s.left), K2 = camera_matrix_of(s.right), D1(s.left.D, true), D2(s.right.D, true), R, T;
  cv::fisheye::stereoCalibrate(object, left_corners, right_corners, K1, D1, K2, D2, cv::Size(640, 480), R, T,
                               cv::fisheye::CALIB_FIX_INTRINSIC,
                               cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
  Eigen::Matrix3d R_cv;
  Eigen::Vector3d T_cv;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R_cv(i, j) = R.at<double>(i, j);
    T_cv(i) = T.at<double>(i);
  }
  const double baseline_difference = std::abs(s.baseline_m() - T_cv.norm()) / T_cv.norm();
  const double rotation_difference = rotation_difference_deg(s.R_right_from_left, R_cv);
  EXPECT_LT(baseline_difference, 0.01);
  EXPECT_LT(rotation_difference, 0.2);
  std::printf("real pairs, fisheye: baseline %.3f mm, RMS %.4f px; fisheye::stereoCalibrate: baseline %.3f mm (difference %.2g%%), "
              "rotation difference %.2g°\n",
              1000 * s.baseline_m(), *s.rms, 1000 * T_cv.norm(), 100 * baseline_difference, rotation_difference);
}

// Pairs with one photo replaced by a blank picture of the camera's size (the board out of one
// camera's view): listed with the reason, not used; the rest calibrate as before.
TEST(CalibStereo, PairsWithTheBoardInOnePhotoAreListedNotUsed) {
  const skylit::test::TempDir dir;
  std::vector<fs::path> left = sample_photos("left"), right = sample_photos("right");
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  ASSERT_TRUE(cv::imwrite((dir / "blank_right.png").string(), blank));
  ASSERT_TRUE(cv::imwrite((dir / "blank_left.png").string(), blank));
  right[2] = dir / "blank_right.png";  // left03.jpg + blank
  left[6] = dir / "blank_left.png";    // blank + right07.jpg
  const BoardDetector detector(sample_board());
  const StereoPhotos photos = skylit::calib::detect_stereo_boards(left, right, detector);
  const StereoResult result = skylit::calib::calibrate_stereo(photos, StereoOptions{});
  EXPECT_EQ(result.used.size(), 11u);
  ASSERT_EQ(result.rejected.size(), 2u);
  EXPECT_EQ(result.rejected[0].name, "left03.jpg + blank_right.png");
  EXPECT_NE(result.rejected[0].reason.find("the board is found in the left photo only"), std::string::npos)
      << result.rejected[0].reason;
  EXPECT_EQ(result.rejected[1].name, "blank_left.png + right07.jpg");
  EXPECT_NE(result.rejected[1].reason.find("the board is found in the right photo only"), std::string::npos)
      << result.rejected[1].reason;
  for (const skylit::calib::UsedPair& used : result.used) {
    EXPECT_EQ(used.name.find("blank"), std::string::npos) << used.name;
  }
  // Each camera still calibrates from every photo it found the board in: 12 each.
  EXPECT_EQ(result.left.used.size(), 12u);
  EXPECT_EQ(result.right.used.size(), 12u);
  const OpenCVStereo fixed = opencv_stereo(result, photos, true);
  EXPECT_LT(std::abs(result.calibration.baseline_m() - fixed.T.norm()) / fixed.T.norm(), 0.01);
  EXPECT_LT(rotation_difference_deg(result.calibration.R_right_from_left, fixed.R), 0.2);
  // The YAML lists them.
  const std::string yaml = skylit::calib::stereo_yaml(result, photos, "test");
  EXPECT_NE(yaml.find("#   left03.jpg + blank_right.png: the board is found in the left photo only"), std::string::npos) << yaml;
}

TEST(CalibStereo, UnequalCountsAndTooFewPairsAreRefused) {
  const BoardDetector detector(sample_board());
  std::vector<fs::path> left = sample_photos("left"), right = sample_photos("right");
  right.pop_back();
  const std::string unequal = skylit::test::error_of([&] { (void)skylit::calib::detect_stereo_boards(left, right, detector); });
  EXPECT_NE(unequal.find("13 left photo(s) but 12 right photo(s)"), std::string::npos) << unequal;
  left.resize(2);
  right.resize(2);
  const StereoPhotos photos = skylit::calib::detect_stereo_boards(left, right, detector);
  StereoOptions options;
  options.left.min_views = options.right.min_views = 2;
  const std::string few = skylit::test::error_of([&] { (void)skylit::calib::calibrate_stereo(photos, options); });
  EXPECT_NE(few.find("2 usable pair(s) of 2; the stereo calibration needs at least 3"), std::string::npos) << few;
}

// ---------------------------------------------------------------------------------------------
// Synthetic pairs: two different pinhole lenses 65 mm apart, the right one turned 1.5° about y and
// 0.4° about x, boards at 0.4–0.55 m.

CameraCalibration synthetic_lens(double fx, double cx, double cy, double k1) {
  CameraCalibration c;
  c.image_width = 640;
  c.image_height = 480;
  c.model = LensModel::Pinhole;
  c.fx = fx;
  c.fy = fx * 0.998;
  c.cx = cx;
  c.cy = cy;
  c.D = {k1, 0.08, 0.0005, -0.0004, -0.01};
  return c;
}

TEST(CalibStereo, SyntheticPairsRecoverTheKnownPose) {
  const CameraCalibration left_truth = synthetic_lens(520, 321.5, 238.0, -0.26);
  const CameraCalibration right_truth = synthetic_lens(528, 317.2, 243.5, -0.24);
  const Eigen::Matrix3d R_truth =
      (Eigen::AngleAxisd(1.5 * kStereoDeg, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(0.4 * kStereoDeg, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const Eigen::Vector3d t_truth(-0.065, 0.0012, -0.0008);
  const skylit::calib_test::BoardRenderer left_renderer(left_truth, 3), right_renderer(right_truth, 3);
  const BoardSpec spec = sample_board();
  const skylit::calib_test::BoardPattern pattern = skylit::calib_test::chessboard_pattern(spec.grid, spec.square_m);
  const Eigen::Vector2d centre(0.5 * (spec.grid.width - 1) * spec.square_m, 0.5 * (spec.grid.height - 1) * spec.square_m);
  struct View {
    double theta_deg, phi_deg, distance, tilt_x_deg, tilt_y_deg, roll_deg;
  };
  const std::vector<View> views{{3, 0, 0.45, 0, 0, 0},       {3, 0, 0.42, 25, 0, 0},     {3, 0, 0.42, 0, 25, 0},
                                {3, 0, 0.42, -20, -20, 10},  {14, 0, 0.48, 10, -20, 0},  {14, 180, 0.48, -10, 20, 0},
                                {11, 90, 0.48, 20, 0, 5},    {11, 270, 0.48, -20, 0, -5}, {15, 35, 0.52, 15, 15, 0},
                                {15, 145, 0.52, 15, -15, 0}, {15, 215, 0.52, -15, -15, 0}, {15, 325, 0.52, -15, 15, 0},
                                {3, 0, 0.42, 35, 0, 0},      {3, 0, 0.42, -35, 0, 0}};
  const BoardDetector detector(spec);
  StereoPhotos photos;
  photos.left.image_size = photos.right.image_size = {640, 480};
  for (std::size_t k = 0; k < views.size(); ++k) {
    const View& v = views[k];
    const skylit::calib_test::BoardPose in_left =
        skylit::calib_test::board_pose(centre, v.theta_deg * kStereoDeg, v.phi_deg * kStereoDeg, v.distance, v.tilt_x_deg * kStereoDeg,
                                       v.tilt_y_deg * kStereoDeg, v.roll_deg * kStereoDeg);
    skylit::calib_test::BoardPose in_right;
    in_right.R_camera_from_board = R_truth * in_left.R_camera_from_board;
    in_right.t_camera_from_board = R_truth * in_left.t_camera_from_board + t_truth;
    PhotoPair pair;
    pair.left_file = "left" + std::to_string(k) + ".png";
    pair.right_file = "right" + std::to_string(k) + ".png";
    const auto found_left = detector.detect(left_renderer.render(pattern, in_left));
    const auto found_right = detector.detect(right_renderer.render(pattern, in_right));
    pair.left = found_left.view;
    pair.right = found_right.view;
    pair.left_reason = found_left.reason;
    pair.right_reason = found_right.reason;
    ASSERT_TRUE(pair.left && pair.right) << pair.name() << ": " << found_left.reason << " / " << found_right.reason;
    photos.left.views.push_back({pair.left_file.string(), *pair.left});
    photos.right.views.push_back({pair.right_file.string(), *pair.right});
    photos.pairs.push_back(pair);
  }
  const StereoResult result = skylit::calib::calibrate_stereo(photos, StereoOptions{});
  const StereoCalibration& s = result.calibration;
  EXPECT_EQ(result.used.size(), views.size());
  const double rotation_error = rotation_difference_deg(s.R_right_from_left, R_truth);
  const double position_error = (s.t_right_from_left - t_truth).norm();
  const double baseline_error = std::abs(s.baseline_m() - t_truth.norm()) / t_truth.norm();
  EXPECT_LT(rotation_error, 0.1);
  EXPECT_LT(position_error, 0.002);  // 2 mm, 3% of the baseline: each lens's own small errors move it
  EXPECT_LT(baseline_error, 0.005);
  EXPECT_LT(*s.rms, 0.15);
  EXPECT_LT(result.rectified_row_error_px, 0.1);
  const Eigen::Vector3d position_mm = 1000 * (s.t_right_from_left - t_truth);
  std::printf("synthetic pairs: rotation %.4f° from the truth, position %.3f mm (%.3f %.3f %.3f), baseline %.3f%%, RMS %.4f px, "
              "rows %.3f px, %d iterations\n",
              rotation_error, 1000 * position_error, position_mm.x(), position_mm.y(), position_mm.z(), 100 * baseline_error, *s.rms,
              result.rectified_row_error_px, result.iterations);

  // The rectification check picture: both halves, the size of two images side by side.
  const cv::Mat picture = skylit::calib::draw_rectification(result, photos.pairs[0], left_renderer.render(pattern, {}),
                                                            right_renderer.render(pattern, {}));
  EXPECT_EQ(picture.size(), cv::Size(1280, 480));
  EXPECT_EQ(picture.type(), CV_8UC3);
}

// ---------------------------------------------------------------------------------------------
// The stereo YAML.

StereoCalibration sample_stereo() {
  StereoCalibration s;
  s.left = synthetic_lens(520, 321.5, 238.0, -0.26);
  s.right = synthetic_lens(528, 317.2, 243.5, -0.24);
  s.right.model = LensModel::Fisheye;
  s.right.D = {0.02, -0.01, 0.003, -0.0005};
  s.R_right_from_left = Eigen::AngleAxisd(1.5 * kStereoDeg, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  s.t_right_from_left = {-0.0645, 0.0011, -0.0004};
  s.rms = 0.21;
  s.per_pair_errors = {0.2, 0.25, 0.18};
  return s;
}

TEST(CalibStereo, YamlRoundTrip) {
  const skylit::test::TempDir dir;
  const fs::path file = dir / "stereo.yaml";
  const StereoCalibration s = sample_stereo();
  skylit::camera::save_stereo_calibration(s, file);
  const StereoCalibration back = skylit::camera::load_stereo_calibration(file);
  EXPECT_EQ(back.file, file);
  EXPECT_EQ(back.left.model, LensModel::Pinhole);
  EXPECT_EQ(back.right.model, LensModel::Fisheye);
  EXPECT_EQ(back.left.fx, s.left.fx);
  EXPECT_EQ(back.right.cy, s.right.cy);
  EXPECT_EQ(back.left.D, s.left.D);
  EXPECT_EQ(back.right.D, s.right.D);
  EXPECT_EQ(back.R_right_from_left, s.R_right_from_left);  // the shortest text that reads back exactly
  EXPECT_EQ(back.t_right_from_left, s.t_right_from_left);
  EXPECT_EQ(back.rms, s.rms);
  EXPECT_EQ(back.per_pair_errors, s.per_pair_errors);
  // Each camera is written in the single-camera schema, under left: and right:.
  const std::string text = skylit::read_file(file);
  EXPECT_NE(text.find("left:\n  image_width: 640\n"), std::string::npos) << text;
  EXPECT_NE(text.find("right:\n  image_width: 640\n"), std::string::npos) << text;
  EXPECT_NE(text.find("R_right_from_left: ["), std::string::npos);
  EXPECT_NE(text.find("t_right_from_left: [-0.0645, 0.0011, "), std::string::npos) << text;
}

// The YAML of `s` (written without validation) with `from` replaced by `to`, read back: the
// InputError's message.
std::string stereo_error(const std::string& from, const std::string& to, const StereoCalibration& s = sample_stereo()) {
  const skylit::test::TempDir dir;
  const fs::path file = dir / "stereo.yaml";
  std::string text = skylit::camera::stereo_calibration_to_yaml(s);
  const std::size_t at = text.find(from);
  if (at == std::string::npos) return "(the sample has no '" + from + "')";
  text.replace(at, from.size(), to);
  std::ofstream(file) << text;
  return skylit::test::error_of([&] { (void)skylit::camera::load_stereo_calibration(file); });
}

TEST(CalibStereo, ReaderErrorsNameTheFieldAndTheFix) {
  // A missing field of a camera: named with its camera.
  std::string e = stereo_error("  fx: 520", "  fz: 520");
  EXPECT_NE(e.find("stereo.yaml"), std::string::npos) << e;
  EXPECT_NE(e.find("left.fz"), std::string::npos) << e;  // unknown field first, with "did you mean"
  e = stereo_error("  fx: 520  # pixels\n", "");
  EXPECT_NE(e.find("left.fx"), std::string::npos) << e;
  EXPECT_NE(e.find("required field is missing"), std::string::npos) << e;
  // A missing stereo field.
  e = stereo_error("t_right_from_left:", "# t_right_from_left:");
  EXPECT_NE(e.find("t_right_from_left"), std::string::npos) << e;
  EXPECT_NE(e.find("required field is missing"), std::string::npos) << e;
  EXPECT_NE(e.find("metres"), std::string::npos) << e;  // the fix
  // R that is not a rotation (a reflection, then a scaled matrix).
  const std::string R_line = "R_right_from_left: [";
  e = stereo_error(R_line, R_line + "-");
  EXPECT_NE(e.find("R_right_from_left"), std::string::npos) << e;
  EXPECT_NE(e.find("not a rotation"), std::string::npos) << e;
  StereoCalibration scaled = sample_stereo();
  scaled.R_right_from_left *= 1.01;
  e = stereo_error("", "", scaled);
  EXPECT_NE(e.find("R_right_from_left"), std::string::npos) << e;
  EXPECT_NE(e.find("not a rotation"), std::string::npos) << e;
  // A zero baseline.
  StereoCalibration together = sample_stereo();
  together.t_right_from_left.setZero();
  e = stereo_error("", "", together);
  EXPECT_NE(e.find("t_right_from_left"), std::string::npos) << e;
  EXPECT_NE(e.find("baseline"), std::string::npos) << e;
}

}  // namespace stereo_calib_test
