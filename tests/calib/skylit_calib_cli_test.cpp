// skylit-calib run as an installer would: the files it writes, its reports, and its errors on
// bad data (which leave an existing output file as it was).
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../cli/cli_support.hpp"
#include "skylit/base/files.hpp"
#include "skylit/calib/orientation.hpp"
#include "skylit/sky/calibration.hpp"
#include "skylit/sky/solar.hpp"
#include "synthetic_sky.hpp"

namespace {

namespace fs = std::filesystem;
using skylit::cli_test::Result;
using skylit::cli_test::TempDir;

constexpr double kDeg = std::numbers::pi / 180.0;
const fs::path kChessboard = skylit::cli_test::kSource / "data" / "chessboard";

Result run_calib(const std::string& args) { return skylit::cli_test::run_program(skylit::cli_test::kBin / "skylit-calib", args); }

std::string q(const fs::path& p) {
  std::string quoted(1, '\'');
  quoted += p.string();
  quoted += '\'';
  return quoted;
}

std::string photos(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& n : names) text.append(" ").append(q(kChessboard / n));
  return text;
}

const char* const kSentinel = "# an earlier calibration that a failed run must not touch\n";

void write_sentinel(const fs::path& file) { std::ofstream(file) << kSentinel; }

bool untouched(const fs::path& file) { return skylit::read_file(file) == kSentinel; }

TEST(SkylitCalibCli, CameraCalibratesTheRealPhotos) {
  const TempDir dir;
  const Result r = run_calib("camera --board 9x6 --square 0.025 -o " + q(dir / "hmd.yaml") + " " + q(kChessboard) + "/*.jpg");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("board found in 13 of 13 photo(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("RMS reprojection error"), std::string::npos);
  EXPECT_NE(r.output.find("per-view errors, worst first"), std::string::npos);
  const skylit::sky::CameraCalibration c = skylit::sky::load_calibration(dir / "hmd.yaml");
  EXPECT_EQ(c.model, skylit::sky::LensModel::Pinhole);
  EXPECT_LT(*c.rms, 0.5);
  EXPECT_EQ(c.per_view_errors.size(), 13u);
  const cv::Mat coverage = cv::imread((dir / "hmd.coverage.png").string());
  EXPECT_EQ(coverage.size(), cv::Size(640, 480));
}

TEST(SkylitCalibCli, FailedRunsLeaveTheOutputAsItWas) {
  const TempDir dir;
  const fs::path out = dir / "hmd.yaml";
  write_sentinel(out);
  // Too few views.
  Result r = run_calib("camera --board 9x6 --square 0.025 -o " + q(out) + photos({"left01.jpg", "left02.jpg"}));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("2 usable view(s) of 2 photo(s); the calibration needs at least 3"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
  // No board found: photos of something else, named with the reason.
  std::string blanks;
  for (const char* name : {"wall1.png", "wall2.png", "wall3.png"}) {
    cv::Mat wall(480, 640, CV_8UC1);
    cv::randu(wall, 90, 140);
    cv::imwrite((dir / name).string(), wall);
    blanks.append(" ").append(q(dir / name));
  }
  r = run_calib("fisheye --board 9x6 --square 0.025 -o " + q(out) + blanks);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("0 usable view(s) of 3 photo(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("wall2.png (no chessboard of 9x6 inner corners found)"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
  EXPECT_FALSE(fs::exists(dir / "hmd.coverage.png"));
  // Bad options.
  r = run_calib("camera --board 9by6 --square 0.025 -o " + q(out) + photos({"left01.jpg"}));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--board"), std::string::npos) << r.output;
  r = run_calib("camera --board 9x6 --charuco 5x7 --square 0.025 -o " + q(out) + photos({"left01.jpg"}));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("both --board and --charuco"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
}

// Tilted 2° off the zenith, image x at bearing 75°.
Eigen::Matrix3d true_orientation() {
  return Eigen::AngleAxisd(2 * kDeg, skylit::calib::Vec3(1, 1, 0).normalized()).toRotationMatrix() *
         skylit::calib::level_compass_rotation(75);
}

std::vector<std::chrono::sys_seconds> times(int count, int every_minutes) {
  std::vector<std::chrono::sys_seconds> out;
  const auto start = skylit::sky::parse_utc("2026-03-20T09:00:00+01:00");
  for (int k = 0; k < count; ++k) out.push_back(start + std::chrono::minutes(every_minutes * k));
  return out;
}

TEST(SkylitCalibCli, SkyOrientationFromTheSun) {
  const TempDir dir;
  skylit::sky::CameraCalibration truth = skylit::calib_test::small_sky_camera(256);
  truth.R_site_from_camera = true_orientation();
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), truth, 48.2, 16.37, times(5, 90), true);  // Vienna
  skylit::sky::CameraCalibration intrinsics = truth;
  intrinsics.R_site_from_camera.setIdentity();
  skylit::sky::save_calibration(intrinsics, dir / "sky.yaml");

  const Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) +
                             " --lat 48.2 --lon 16.37 -o " + q(dir / "oriented.yaml"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("sun in 5 of 5 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("residual"), std::string::npos);
  const skylit::sky::CameraCalibration oriented = skylit::sky::load_calibration(dir / "oriented.yaml");
  EXPECT_LT(skylit::calib::rotation_difference_deg(oriented.R_site_from_camera, truth.R_site_from_camera), 0.5);
  EXPECT_DOUBLE_EQ(oriented.fx, truth.fx);
  EXPECT_TRUE(fs::exists(dir / "oriented.orientation.png"));
  EXPECT_TRUE(skylit::sky::load_calibration(dir / "sky.yaml").R_site_from_camera.isIdentity()) << "-o leaves --calib alone";
}

TEST(SkylitCalibCli, SkyOrientationWithoutSunFailsCleanly) {
  const TempDir dir;
  const skylit::sky::CameraCalibration camera = skylit::calib_test::small_sky_camera(128);
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), camera, 48.2, 16.37, times(3, 60), false);
  skylit::sky::save_calibration(camera, dir / "sky.yaml");
  const std::string before = skylit::read_file(dir / "sky.yaml");
  Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) + " --lat 48.2 --lon 16.37");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("no sun seen in 3 of 3 frame(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--level-compass"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(dir / "sky.yaml"), before);
  // Frames without the site's position.
  r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--lat"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(dir / "sky.yaml"), before);
}

TEST(SkylitCalibCli, SkyOrientationFromLevelAndCompass) {
  const TempDir dir;
  skylit::sky::save_calibration(skylit::calib_test::small_sky_camera(128), dir / "sky.yaml");
  const Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --level-compass 80 --declination 7.5");
  ASSERT_EQ(r.status, 0) << r.output;
  const skylit::sky::CameraCalibration c = skylit::sky::load_calibration(dir / "sky.yaml");
  EXPECT_LT(skylit::calib::rotation_difference_deg(c.R_site_from_camera, skylit::calib::level_compass_rotation(87.5)), 1e-6);
  EXPECT_NE(skylit::read_file(dir / "sky.yaml").find("bearing 87.50° true"), std::string::npos);
}

}  // namespace
