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
#include "skylit/camera/lens.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_render.hpp"
#include "synthetic_markers.hpp"
#include "synthetic_sky.hpp"

namespace skylit_calib_cli_test {  // named, not anonymous: the test program is one unity build

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
  const Result r = run_calib("camera --board 9x6 --square 0.025 -o " + q(dir / "hmd.yaml") + " " + q(kChessboard) + "/left*.jpg");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("board found in 13 of 13 photo(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("RMS reprojection error"), std::string::npos);
  EXPECT_NE(r.output.find("per-view errors, worst first"), std::string::npos);
  const skylit::camera::CameraCalibration c = skylit::camera::load_calibration(dir / "hmd.yaml");
  EXPECT_EQ(c.model, skylit::camera::LensModel::Pinhole);
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
  skylit::camera::CameraCalibration truth = skylit::calib_test::small_sky_camera(256);
  truth.R_site_from_camera = true_orientation();
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), truth, 48.2, 16.37, times(5, 90), true);  // Vienna
  skylit::camera::CameraCalibration intrinsics = truth;
  intrinsics.R_site_from_camera.setIdentity();
  skylit::camera::save_calibration(intrinsics, dir / "sky.yaml");

  const Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) +
                             " --lat 48.2 --lon 16.37 -o " + q(dir / "oriented.yaml"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("sun in 5 of 5 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("residual"), std::string::npos);
  const skylit::camera::CameraCalibration oriented = skylit::camera::load_calibration(dir / "oriented.yaml");
  EXPECT_LT(skylit::calib::rotation_difference_deg(oriented.R_site_from_camera, truth.R_site_from_camera), 0.5);
  EXPECT_DOUBLE_EQ(oriented.fx, truth.fx);
  EXPECT_TRUE(fs::exists(dir / "oriented.orientation.png"));
  EXPECT_TRUE(skylit::camera::load_calibration(dir / "sky.yaml").R_site_from_camera.isIdentity()) << "-o leaves --calib alone";
}

// The longitude's sign wrong: the frames fit one rotation, but one that puts the sky camera where
// no sky camera looks. Refused, naming the likely cause; nothing written.
TEST(SkylitCalibCli, SkyOrientationWithTheLongitudesSignWrongIsRefused) {
  const TempDir dir;
  skylit::camera::CameraCalibration truth = skylit::calib_test::small_sky_camera(256);
  truth.R_site_from_camera = true_orientation();
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), truth, 48.2, 16.37, times(5, 90), true);
  skylit::camera::CameraCalibration intrinsics = truth;
  intrinsics.R_site_from_camera.setIdentity();
  skylit::camera::save_calibration(intrinsics, dir / "sky.yaml");
  const Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) +
                             " --lat 48.2 --lon -16.37 -o " + q(dir / "oriented.yaml"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("from the zenith"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--lon with the wrong sign"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "oriented.yaml"));
}

TEST(SkylitCalibCli, SkyOrientationWithoutSunFailsCleanly) {
  const TempDir dir;
  const skylit::camera::CameraCalibration camera = skylit::calib_test::small_sky_camera(128);
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), camera, 48.2, 16.37, times(3, 60), false);
  skylit::camera::save_calibration(camera, dir / "sky.yaml");
  const std::string before = skylit::read_file(dir / "sky.yaml");
  Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) + " --lat 48.2 --lon 16.37 --in-place");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("no sun seen in 3 of 3 frame(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--level-compass"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(dir / "sky.yaml"), before);
  // Frames without the site's position.
  r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --frames " + q(csv) + " --in-place");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--lat"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(dir / "sky.yaml"), before);
}

TEST(SkylitCalibCli, SkyOrientationFromLevelAndCompass) {
  const TempDir dir;
  skylit::camera::save_calibration(skylit::calib_test::small_sky_camera(128), dir / "sky.yaml");
  // Without -o or --in-place the calibration is never replaced.
  const std::string before = skylit::read_file(dir / "sky.yaml");
  const Result refused = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --level-compass 80");
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_NE(refused.output.find("--in-place"), std::string::npos) << refused.output;
  EXPECT_EQ(skylit::read_file(dir / "sky.yaml"), before);
  const Result r = run_calib("sky-orientation --calib " + q(dir / "sky.yaml") + " --level-compass 80 --declination 7.5 --in-place");
  ASSERT_EQ(r.status, 0) << r.output;
  const skylit::camera::CameraCalibration c = skylit::camera::load_calibration(dir / "sky.yaml");
  EXPECT_LT(skylit::calib::rotation_difference_deg(c.R_site_from_camera, skylit::calib::level_compass_rotation(87.5)), 1e-6);
  EXPECT_NE(skylit::read_file(dir / "sky.yaml").find("bearing 87.50° true"), std::string::npos);
}


// The survey site of synthetic_markers.hpp photographed from its eight places, as PNG files, and
// the camera's calibration; the photos' names, quoted, for the command line.
std::string write_site_photos(const fs::path& dir) {
  const skylit::camera::CameraCalibration camera = skylit::calib_test::survey_camera();
  skylit::camera::save_calibration(camera, dir / "hmd.yaml");
  const skylit::camera::Lens lens(camera);
  skylit::track::MarkerRenderOptions render;
  render.supersampling = 3;
  std::string names;
  int k = 0;
  for (const skylit::track::Pose& pose : skylit::calib_test::survey_viewpoints()) {
    render.seed = static_cast<std::uint64_t>(++k);
    const fs::path file = dir / ("site" + std::to_string(k) + ".png");
    cv::imwrite(file.string(), skylit::track::render_markers(skylit::calib_test::survey_site(), lens, pose, render));
    names.append(" ").append(q(file));
  }
  return names;
}

TEST(SkylitCalibCli, MarkersMapsTheSiteFromPhotos) {
  const TempDir dir;
  const std::string site_photos = write_site_photos(dir.path());
  const Result r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --origin 0 --size 0.2 --tag-size 5=0.2 -o " +
                             q(dir / "site_tags.yaml") + site_photos);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("tags found in 8 of 8 photo(s) (tag36h11, origin tag 0)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("6 tag(s) mapped from 8 posed photo(s); RMS reprojection error"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("(origin, fixed)"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("advice:"), std::string::npos) << "good data need no advice:\n" << r.output;
  const skylit::track::MarkerMap map = skylit::track::load_marker_map(dir / "site_tags.yaml");
  const skylit::track::MarkerMap truth = skylit::calib_test::survey_site();
  ASSERT_EQ(map.tags.size(), truth.tags.size());
  for (const skylit::track::MarkerTag& expected : truth.tags) {
    const skylit::track::MarkerTag* found = map.find(expected.id);
    ASSERT_NE(found, nullptr) << expected.id;
    EXPECT_LT(skylit::calib_test::position_error_m(*found, expected), 0.01) << expected.id;
    EXPECT_LT(skylit::calib_test::rotation_error_deg(*found, expected), 0.5) << expected.id;
  }
  const cv::Mat plan = cv::imread((dir / "site_tags.markers.png").string());
  EXPECT_FALSE(plan.empty()) << "the diagnostic plan beside the map";
}

TEST(SkylitCalibCli, MarkersFailsCleanlyAndAdvises) {
  const TempDir dir;
  const std::string site_photos = write_site_photos(dir.path());
  const fs::path out = dir / "site_tags.yaml";
  write_sentinel(out);
  // An origin that is in no photo.
  Result r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --origin 42 --size 0.2 -o " + q(out) + site_photos);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("the origin tag 42 is in none of the 8 photo(s) (tags seen: 0, 1, 2, 3, 4, 5)"), std::string::npos)
      << r.output;
  EXPECT_TRUE(untouched(out));
  EXPECT_FALSE(fs::exists(dir / "site_tags.markers.png"));
  // One photo: too few views.
  r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --size 0.2 -o " + q(out) + " " + q(dir / "site1.png"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("too few views"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
  // Bad options.
  r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --size 0.2 --tag-size 3:0.16 -o " + q(out) + site_photos);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--tag-size"), std::string::npos) << r.output;
  r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " -o " + q(out) + site_photos);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("no tag size given"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
  r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --size 0.2 --origin-pose 0,0,0,2,0,0,0 -o " + q(out) + site_photos);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.output.find("--origin-pose"), std::string::npos) << r.output;
  EXPECT_TRUE(untouched(out));
  // Three photos from the middle of the arc: a map, with advice to take more.
  r = run_calib("markers --camera " + q(dir / "hmd.yaml") + " --size 0.2 --origin-pose 0,0,0,1,0,0,0 -o " + q(out) + " --image-out " +
                q(dir / "plan.png") + " " + q(dir / "site4.png") + " " + q(dir / "site5.png") + " " + q(dir / "site6.png"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("advice: only 3 photo(s) are posed"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(dir / "plan.png"));
  EXPECT_FALSE(untouched(out));
}

TEST(SkylitCalibCli, HidListShowsTheDevicesAndTheirProfiles) {
  const TempDir dir;
  const Result r = run_calib("hid list --profiles " + q(skylit::cli_test::kSource / "config" / "imu") + " -o " +
                             q(dir / "hid.yaml"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("1 IMU profile(s) from"), std::string::npos) << r.output;
  const std::string yaml = skylit::read_file(dir / "hid.yaml");
  if (r.output.find("skylit-calib hid list: no HID devices found") != std::string::npos) {
    // A machine without HID devices (the build machines): say so, and what to check.
    EXPECT_NE(r.output.find("advice: plug the IMU in"), std::string::npos) << r.output;
    EXPECT_NE(yaml.find("devices: []"), std::string::npos) << yaml;
  } else {
    EXPECT_NE(r.output.find("HID device(s)"), std::string::npos) << r.output;
    EXPECT_NE(yaml.find("  - id: \""), std::string::npos) << yaml;
  }
  // A profile folder that is not there.
  const Result bad = run_calib("hid list --profiles " + q(dir / "no_such_folder"));
  EXPECT_EQ(bad.status, 2);
  EXPECT_NE(bad.output.find("--profiles"), std::string::npos) << bad.output;
  // `hid` alone asks for its subcommand.
  EXPECT_NE(run_calib("hid").status, 0);
}

}  // namespace
