// Intrinsics from board photos: synthetic photos through known lenses (fisheye and pinhole) give
// the lens back; the real chessboard photos in data/chessboard calibrate to a small error; bad
// data give clear errors.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/calib/board.hpp"
#include "skylit/calib/intrinsics.hpp"
#include "skylit/camera/lens.hpp"
#include "synthetic_board.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::calib::BoardDetector;
using skylit::calib::BoardSpec;
using skylit::calib::IntrinsicsOptions;
using skylit::calib::IntrinsicsResult;
using skylit::calib::NamedView;
using skylit::calib_test::board_pose;
using skylit::calib_test::BoardRenderer;
using skylit::camera::CameraCalibration;
using skylit::camera::LensModel;

constexpr double kDeg = std::numbers::pi / 180.0;

struct ViewSpec {
  double theta_deg, phi_deg, distance, tilt_x_deg, tilt_y_deg, roll_deg;
};

CameraCalibration pinhole_truth() {
  CameraCalibration c;
  c.image_width = 640;
  c.image_height = 480;
  c.model = LensModel::Pinhole;
  c.fx = 520;
  c.fy = 515;
  c.cx = 323.5;
  c.cy = 236.2;
  c.D = {-0.28, 0.09, 0.0008, -0.0005, -0.012};
  return c;
}

// A sky-camera lens: about 190° across the 640-pixel square, Kannala–Brandt with mild terms.
CameraCalibration fisheye_truth() {
  CameraCalibration c;
  c.image_width = 640;
  c.image_height = 640;
  c.model = LensModel::Fisheye;
  c.fx = 196;
  c.fy = 195.2;
  c.cx = 321.3;
  c.cy = 317.8;
  c.D = {0.03, -0.012, 0.004, -0.0008};
  return c;
}

BoardSpec chessboard_9x6() {
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.03;
  return spec;
}

std::vector<NamedView> render_views(const BoardSpec& spec, const std::vector<ViewSpec>& poses,
                                    const skylit::calib_test::BoardPattern& pattern, const BoardRenderer& renderer,
                                    std::vector<std::string>* missed) {
  const BoardDetector detector(spec);
  const Eigen::Vector2d centre(0.5 * (spec.grid.width - 1) * spec.square_m, 0.5 * (spec.grid.height - 1) * spec.square_m);
  std::vector<NamedView> views;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const ViewSpec& v = poses[k];
    const cv::Mat image = renderer.render(pattern, board_pose(centre, v.theta_deg * kDeg, v.phi_deg * kDeg, v.distance,
                                                              v.tilt_x_deg * kDeg, v.tilt_y_deg * kDeg, v.roll_deg * kDeg));
    auto found = detector.detect(image);
    const std::string name = "view" + std::to_string(k);
    if (found.view) {
      views.push_back({name, *found.view});
    } else if (missed) {
      missed->push_back(name + ": " + found.reason);
    }
  }
  return views;
}

// The largest distance (pixels) between where the true and the recovered lens put the same
// direction, over the pixels whose direction is within `max_theta_deg` of the axis.
double max_projection_difference(const CameraCalibration& truth, const CameraCalibration& recovered, double max_theta_deg) {
  const skylit::camera::Lens a(truth), b(recovered);
  double worst = 0;
  for (int y = 0; y < truth.image_height; y += 8) {
    for (int x = 0; x < truth.image_width; x += 8) {
      const auto d = a.unproject({x, y});
      if (!d || std::acos(std::clamp(d->z(), -1.0, 1.0)) > max_theta_deg * kDeg) continue;
      const auto p = b.project(*d);
      if (!p) return 1e9;
      worst = std::max(worst, (*p - skylit::camera::Vec2(x, y)).norm());
    }
  }
  return worst;
}

TEST(CalibIntrinsics, SyntheticPinholeRecoversTheLens) {
  const CameraCalibration truth = pinhole_truth();
  const BoardRenderer renderer(truth, 3);
  const BoardSpec spec = chessboard_9x6();
  const std::vector<ViewSpec> poses{
      {0, 0, 0.50, 0, 0, 0},     {0, 0, 0.45, 25, 0, 0},      {0, 0, 0.45, 0, 25, 0},       {0, 0, 0.45, -20, -20, 10},
      {17, 0, 0.50, 10, -20, 0}, {17, 180, 0.50, -10, 20, 0}, {14, 90, 0.50, 20, 0, 5},     {14, 270, 0.50, -20, 0, -5},
      {20, 35, 0.55, 15, 15, 0}, {20, 145, 0.55, 15, -15, 0}, {20, 215, 0.55, -15, -15, 0}, {20, 325, 0.55, -15, 15, 0},
      {0, 0, 0.45, 40, 0, 0},    {0, 0, 0.45, -40, 0, 0},     {0, 0, 0.45, 0, 40, 0},       {0, 0, 0.45, 0, -40, 0}};
  std::vector<std::string> missed;
  std::vector<NamedView> views =
      render_views(spec, poses, skylit::calib_test::chessboard_pattern(spec.grid, spec.square_m), renderer, &missed);
  for (const std::string& m : missed) ADD_FAILURE() << m;
  IntrinsicsOptions options;
  options.model = LensModel::Pinhole;
  const IntrinsicsResult result =
      skylit::calib::calibrate_intrinsics(views, {}, {truth.image_width, truth.image_height}, options);
  const CameraCalibration& c = result.calibration;
  EXPECT_EQ(result.used.size(), poses.size());
  ASSERT_EQ(c.D.size(), 5u);
  // Tolerances: focal lengths 0.3 %, principal point 1 px, k1 0.01, and the whole lens model
  // (K and D) within 0.5 px of the true one out to 30° from the axis (where the boards were; the
  // image's corners, at 38°, are extrapolation).
  EXPECT_NEAR(c.fx, truth.fx, 0.003 * truth.fx);
  EXPECT_NEAR(c.fy, truth.fy, 0.003 * truth.fy);
  EXPECT_NEAR(c.cx, truth.cx, 1.0);
  EXPECT_NEAR(c.cy, truth.cy, 1.0);
  EXPECT_NEAR(c.D[0], truth.D[0], 0.01);
  const double model_difference = max_projection_difference(truth, c, 30);
  EXPECT_LT(model_difference, 0.5);
  EXPECT_LT(*c.rms, 0.15);
  ASSERT_EQ(c.per_view_errors.size(), result.used.size());
  EXPECT_GT(result.coverage, 0.5);
  EXPECT_TRUE(c.R_site_from_camera.isIdentity());
  EXPECT_TRUE(result.advice.empty()) << result.advice.front();
  std::printf(
      "pinhole: fx %.3f fy %.3f cx %.3f cy %.3f D [%.4f %.4f %.5f %.5f %.4f] rms %.4f px, model difference %.3f px (30°), "
      "coverage %.2f\n",
      c.fx, c.fy, c.cx, c.cy, c.D[0], c.D[1], c.D[2], c.D[3], c.D[4], *c.rms, model_difference, result.coverage);
}

TEST(CalibIntrinsics, SyntheticFisheyeRecoversTheLens) {
  const CameraCalibration truth = fisheye_truth();
  const BoardRenderer renderer(truth, 3);
  const BoardSpec spec = chessboard_9x6();
  const std::vector<ViewSpec> poses{{0, 0, 0.35, 0, 0, 0},      {0, 0, 0.30, 30, 0, 0},     {0, 0, 0.30, 0, -30, 20},
                                    {35, 0, 0.35, 0, 10, 0},    {35, 90, 0.35, 10, 0, 0},   {35, 180, 0.35, 0, -10, 0},
                                    {35, 270, 0.35, -10, 0, 0}, {60, 45, 0.35, 0, 0, 0},    {60, 135, 0.35, 0, 0, 30},
                                    {60, 225, 0.35, 0, 0, 0},   {60, 315, 0.35, 0, 0, -30}, {55, 0, 0.30, 0, 0, 90},
                                    {55, 180, 0.30, 0, 0, 90},  {75, 90, 0.30, 0, 0, 0},    {75, 270, 0.30, 0, 0, 0}};
  std::vector<std::string> missed;
  std::vector<NamedView> views =
      render_views(spec, poses, skylit::calib_test::chessboard_pattern(spec.grid, spec.square_m), renderer, &missed);
  // Every board is found (near the rim by the sector-based detector).
  for (const std::string& m : missed) ADD_FAILURE() << m;
  IntrinsicsOptions options;
  options.model = LensModel::Fisheye;
  const IntrinsicsResult result =
      skylit::calib::calibrate_intrinsics(views, {}, {truth.image_width, truth.image_height}, options);
  const CameraCalibration& c = result.calibration;
  EXPECT_EQ(result.used.size(), poses.size()) << "no view rejected as ill-conditioned or an outlier";
  ASSERT_EQ(c.D.size(), 4u);
  // Tolerances: focal lengths 0.5 %, principal point 1 px, and the lens model within 0.3 px of
  // the true one out to 75° from the axis (where the boards were).
  EXPECT_GT(result.coverage, 0.5);
  EXPECT_NEAR(c.fx, truth.fx, 0.005 * truth.fx);
  EXPECT_NEAR(c.fy, truth.fy, 0.005 * truth.fy);
  EXPECT_NEAR(c.cx, truth.cx, 1.0);
  EXPECT_NEAR(c.cy, truth.cy, 1.0);
  const double model_difference = max_projection_difference(truth, c, 75);
  EXPECT_LT(model_difference, 0.3);
  EXPECT_LT(*c.rms, 0.15);
  std::printf(
      "fisheye: %zu views, fx %.3f fy %.3f cx %.3f cy %.3f D [%.4f %.4f %.4f %.4f] rms %.4f px, model difference %.3f px "
      "(75°), coverage %.2f\n",
      result.used.size(), c.fx, c.fy, c.cx, c.cy, c.D[0], c.D[1], c.D[2], c.D[3], *c.rms, model_difference, result.coverage);
}

// ChArUco: a board rendered from OpenCV's own drawing, seen through the pinhole lens. The
// corners found are where the true lens puts the board's corners, by id.
TEST(CalibIntrinsics, SyntheticCharucoCornersAndCalibration) {
  const CameraCalibration truth = pinhole_truth();
  const BoardRenderer renderer(truth, 3);
  BoardSpec spec;
  spec.kind = BoardSpec::Kind::Charuco;
  spec.grid = {5, 7};
  spec.square_m = 0.04;
  spec.marker_m = 0.03;
  spec.dictionary = "4x4_50";
  const auto board =
      cv::aruco::CharucoBoard::create(5, 7, 0.04f, 0.03f, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50));
  const int px = 60;  // texture pixels per square
  cv::Mat texture;
  board->draw(cv::Size(5 * px, 7 * px), texture, 0, 1);
  // OpenCV's board coordinates have y up; its drawing has row 0 at the top (largest y).
  const double width = 5 * 0.04, height = 7 * 0.04;
  const skylit::calib_test::BoardPattern pattern = [&](double x, double y) -> float {
    if (x < -0.02 || y < -0.02 || x > width + 0.02 || y > height + 0.02) return -1.0f;
    const int u = static_cast<int>(std::floor(x / width * texture.cols));
    const int v = static_cast<int>(std::floor(y / height * texture.rows));
    if (u < 0 || v < 0 || u >= texture.cols || v >= texture.rows) return 1.0f;  // white margin
    return texture.at<std::uint8_t>(v, u) / 255.0f;
  };
  const BoardDetector detector(spec);
  const std::vector<ViewSpec> poses{{0, 0, 0.55, 0, 0, 0},     {0, 0, 0.5, 25, 0, 0},    {0, 0, 0.5, 0, 25, 0},
                                    {12, 0, 0.6, 0, -20, 0},   {12, 180, 0.6, 0, 20, 0}, {10, 90, 0.6, 20, 0, 0},
                                    {10, 270, 0.6, -20, 0, 0}, {15, 45, 0.6, 15, 15, 10}};
  std::vector<NamedView> views;
  const Eigen::Vector2d centre(0.5 * width, 0.5 * height);
  const skylit::camera::Lens lens(truth);
  double worst = 0, sum = 0;
  int count = 0;
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const ViewSpec& v = poses[k];
    const auto pose = board_pose(centre, v.theta_deg * kDeg, v.phi_deg * kDeg, v.distance, v.tilt_x_deg * kDeg,
                                 v.tilt_y_deg * kDeg, v.roll_deg * kDeg);
    const auto found = detector.detect(renderer.render(pattern, pose));
    ASSERT_TRUE(found.view) << "view " << k << ": " << found.reason;
    EXPECT_GE(found.view->object.size(), 12u) << "of 24";
    for (std::size_t i = 0; i < found.view->object.size(); ++i) {
      const cv::Point3f& o = found.view->object[i];
      const auto expected = lens.project(pose.R_camera_from_board * Eigen::Vector3d(o.x, o.y, o.z) + pose.t_camera_from_board);
      ASSERT_TRUE(expected);
      const double e = (*expected - skylit::camera::Vec2(found.view->image[i].x, found.view->image[i].y)).norm();
      worst = std::max(worst, e);
      sum += e;
      ++count;
    }
    views.push_back({"charuco" + std::to_string(k), *found.view});
  }
  // Corners against where the true lens puts them: 0.15 px on average, 0.5 px at worst.
  EXPECT_LT(sum / count, 0.15);
  EXPECT_LT(worst, 0.5);
  IntrinsicsOptions options;
  options.model = LensModel::Pinhole;
  const IntrinsicsResult result =
      skylit::calib::calibrate_intrinsics(views, {}, {truth.image_width, truth.image_height}, options);
  EXPECT_NEAR(result.calibration.fx, truth.fx, 0.01 * truth.fx);
  EXPECT_NEAR(result.calibration.fy, truth.fy, 0.01 * truth.fy);
  EXPECT_LT(*result.calibration.rms, 0.2);
  std::printf("charuco: %d corners, mean error %.3f px, worst %.3f px, fx %.2f fy %.2f rms %.3f\n", count, sum / count, worst,
              result.calibration.fx, result.calibration.fy, *result.calibration.rms);
}

const fs::path kChessboard = fs::path(SKYLIT_SOURCE_DIR) / "data" / "chessboard";

std::vector<fs::path> chessboard_photos() {
  std::vector<fs::path> photos;
  for (const auto& entry : fs::directory_iterator(kChessboard)) {
    // The left camera's photos (the right camera's, right*.jpg, are the stereo tests').
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".jpg" && name.starts_with("left")) photos.push_back(entry.path());
  }
  std::sort(photos.begin(), photos.end());
  return photos;
}

// The real photos (OpenCV's sample set): 13 photos of a 9x6 chessboard with 25 mm squares.
TEST(CalibIntrinsics, RealChessboardPhotosCalibrateUnderHalfAPixel) {
  const std::vector<fs::path> photos = chessboard_photos();
  ASSERT_EQ(photos.size(), 13u);
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.025;
  const BoardDetector detector(spec);
  const skylit::calib::BoardPhotos found = skylit::calib::detect_boards(photos, detector);
  EXPECT_EQ(found.views.size(), 13u);
  EXPECT_EQ(found.image_size, cv::Size(640, 480));
  IntrinsicsOptions options;
  options.model = LensModel::Pinhole;
  const IntrinsicsResult result = skylit::calib::calibrate_intrinsics(found.views, found.rejected, found.image_size, options);
  EXPECT_LT(*result.calibration.rms, 0.5);
  EXPECT_EQ(result.used.size(), 13u);
  // A 640×480 webcam with about 62° across: fx near 535 px, the principal point near the centre.
  EXPECT_NEAR(result.calibration.fx, 535, 15);
  EXPECT_NEAR(result.calibration.cx, 320, 30);
  EXPECT_NEAR(result.calibration.cy, 240, 30);
  // The YAML reads back through the schema's reader, rms and per-view errors included.
  const skylit::test::TempDir dir;
  const fs::path file = dir / "real.yaml";
  skylit::write_file_atomic(file, skylit::calib::intrinsics_yaml(result, "test"));
  const CameraCalibration back = skylit::camera::load_calibration(file);
  EXPECT_EQ(back.model, LensModel::Pinhole);
  EXPECT_DOUBLE_EQ(back.fx, result.calibration.fx);
  ASSERT_EQ(back.D.size(), 5u);
  EXPECT_DOUBLE_EQ(*back.rms, *result.calibration.rms);
  EXPECT_EQ(back.per_view_errors.size(), 13u);
  // The coverage image: the frame's size, with the corners drawn.
  const cv::Mat coverage = skylit::calib::draw_coverage(result, found.first_image);
  EXPECT_EQ(coverage.size(), cv::Size(640, 480));
  std::printf("real chessboard: rms %.3f px, fx %.2f fy %.2f cx %.2f cy %.2f, coverage %.2f\n", *result.calibration.rms,
              result.calibration.fx, result.calibration.fy, result.calibration.cx, result.calibration.cy, result.coverage);
}

TEST(CalibIntrinsics, TooFewViewsSaysWhatToDo) {
  const std::vector<fs::path> photos = chessboard_photos();
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.025;
  const BoardDetector detector(spec);
  const std::vector<fs::path> two(photos.begin(), photos.begin() + 2);
  skylit::calib::BoardPhotos found = skylit::calib::detect_boards(two, detector);
  found.rejected.push_back({"blurred.jpg", "no chessboard of 9x6 inner corners found"});
  try {
    skylit::calib::calibrate_intrinsics(found.views, found.rejected, found.image_size, {});
    FAIL() << "expected InputError";
  } catch (const skylit::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("2 usable view(s) of 3 photo(s)"), std::string::npos) << message;
    EXPECT_NE(message.find("at least 3"), std::string::npos) << message;
    EXPECT_NE(message.find("blurred.jpg"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
}

TEST(CalibIntrinsics, PhotosWithoutABoardAreRejectedByName) {
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.025;
  const BoardDetector detector(spec);
  // A photo with the board, a missing file, and a blank frame.
  const std::vector<fs::path> photos{kChessboard / "left01.jpg", kChessboard / "missing.jpg"};
  const skylit::calib::BoardPhotos found = skylit::calib::detect_boards(photos, detector);
  ASSERT_EQ(found.views.size(), 1u);
  ASSERT_EQ(found.rejected.size(), 1u);
  EXPECT_EQ(found.rejected[0].name, "missing.jpg");
  EXPECT_EQ(found.rejected[0].reason, "no such file");
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
  const auto none = detector.detect(blank);
  EXPECT_FALSE(none.view);
  EXPECT_EQ(none.reason, "no chessboard of 9x6 inner corners found");
}

// A stray picture of another size among the board photos, even the first one in the folder: the
// size most photos have is the camera's, the stray one is listed as not used, and the
// calibration goes on.
TEST(CalibIntrinsics, AStrayPhotoOfAnotherSizeIsLeftOutNotTheRest) {
  const skylit::test::TempDir dir;
  std::vector<fs::path> photos{dir.path() / "aaa_holiday.jpg"};
  cv::imwrite(photos.front().string(), cv::Mat(300, 400, CV_8UC3, cv::Scalar(90, 140, 200)));
  for (const fs::path& photo : chessboard_photos()) photos.push_back(photo);
  BoardSpec spec;
  spec.grid = {9, 6};
  spec.square_m = 0.025;
  const skylit::calib::BoardPhotos found = skylit::calib::detect_boards(photos, BoardDetector(spec));
  EXPECT_EQ(found.image_size, cv::Size(640, 480));
  EXPECT_EQ(found.views.size(), 13u);
  EXPECT_EQ(found.first_image.size(), cv::Size(640, 480));
  ASSERT_EQ(found.rejected.size(), 1u);
  EXPECT_EQ(found.rejected[0].name, "aaa_holiday.jpg");
  EXPECT_EQ(found.rejected[0].reason, "its size 400x300 differs from the size most photos have, 640x480 (13 photos)");
  IntrinsicsOptions options;
  options.model = LensModel::Pinhole;
  const IntrinsicsResult result = skylit::calib::calibrate_intrinsics(found.views, found.rejected, found.image_size, options);
  EXPECT_LT(*result.calibration.rms, 0.5);
}

}  // namespace
