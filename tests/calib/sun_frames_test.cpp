// Sky frames to sun observations: the frame list, the sun found through the lens against the
// solar position, and the orientation recovered end to end from rendered frames.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <libexif/exif-data.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../cli/cli_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/calib/orientation.hpp"
#include "skylit/calib/sun_frames.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/camera/lens.hpp"
#include "synthetic_sky.hpp"

namespace sun_frames_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using skylit::calib::Vec3;
using skylit::cli_test::TempDir;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kLatitude = 35.01, kLongitude = 135.77;  // Kyoto

std::vector<std::chrono::sys_seconds> day_times(int count, int every_minutes) {
  std::vector<std::chrono::sys_seconds> times;
  const auto start = skylit::sky::parse_utc("2026-06-21T08:30:00+09:00");
  for (int k = 0; k < count; ++k) times.push_back(start + std::chrono::minutes(every_minutes * k));
  return times;
}

// Tilted 3° off the zenith, image x at bearing 200°.
Eigen::Matrix3d true_orientation() {
  return Eigen::AngleAxisd(3 * kDeg, Vec3(2, -1, 0).normalized()).toRotationMatrix() * skylit::calib::level_compass_rotation(200);
}

TEST(SunFrames, ReadsTheFrameList) {
  const TempDir dir;
  std::ofstream(dir / "frames.csv") << "timestamp,file,sun_azimuth_deg\n"
                                       "2026-06-21T09:00:00+09:00,a.exr,90\n"
                                       "# a comment\n"
                                       "2026-06-21T01:30:00Z,sub/b.png,100\n";
  const auto frames = skylit::calib::read_frame_list(dir / "frames.csv");
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].file, dir / "a.exr");
  EXPECT_EQ(frames[1].file, dir / "sub/b.png");
  EXPECT_EQ(skylit::sky::format_utc(frames[0].utc), "2026-06-21T00:00:00Z");
  EXPECT_EQ(skylit::sky::format_utc(frames[1].utc), "2026-06-21T01:30:00Z");

  std::ofstream(dir / "bad.csv") << "timestamp,file\n2026-06-21T09:00:00+09:00,a.exr\n2026-06-21 09:00,b.exr\n";
  try {
    skylit::calib::read_frame_list(dir / "bad.csv");
    FAIL();
  } catch (const skylit::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("bad.csv:3:"), std::string::npos) << message;
    EXPECT_NE(message.find("timestamp"), std::string::npos) << message;
  }
  std::ofstream(dir / "noheader.csv") << "a.exr,2026-06-21T09:00:00Z\n";
  EXPECT_THROW(skylit::calib::read_frame_list(dir / "noheader.csv"), skylit::InputError);
}

// A small JPEG with EXIF DateTimeOriginal (and OffsetTimeOriginal when `zone` is not empty), as
// a camera writes it: an APP1 segment after the start-of-image marker.
void write_photo_with_time(const fs::path& file, const std::string& taken, const std::string& zone) {
  ExifData* data = exif_data_new();
  exif_data_set_byte_order(data, EXIF_BYTE_ORDER_INTEL);
  const auto add_text = [&](ExifTag tag, const std::string& text) {
    ExifEntry* entry = exif_entry_new();
    entry->tag = tag;
    entry->format = EXIF_FORMAT_ASCII;
    entry->components = text.size() + 1;
    entry->size = static_cast<unsigned int>(text.size() + 1);
    entry->data = static_cast<unsigned char*>(std::malloc(entry->size));  // libexif frees it
    std::memcpy(entry->data, text.c_str(), entry->size);
    exif_content_add_entry(data->ifd[EXIF_IFD_EXIF], entry);
    exif_entry_unref(entry);
  };
  add_text(EXIF_TAG_DATE_TIME_ORIGINAL, taken);
  if (!zone.empty()) add_text(EXIF_TAG_OFFSET_TIME_ORIGINAL, zone);
  unsigned char* exif = nullptr;
  unsigned int exif_size = 0;
  exif_data_save_data(data, &exif, &exif_size);
  exif_data_unref(data);
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", cv::Mat(16, 16, CV_8UC3, cv::Scalar(200, 150, 100)), jpeg);
  const unsigned length = exif_size + 2;
  std::vector<unsigned char> app1{0xFF, 0xE1, static_cast<unsigned char>(length >> 8), static_cast<unsigned char>(length & 0xFF)};
  app1.insert(app1.end(), exif, exif + exif_size);
  std::free(exif);
  jpeg.insert(jpeg.begin() + 2, app1.begin(), app1.end());
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(jpeg.data()), static_cast<std::streamsize>(jpeg.size()));
}

TEST(SunFrames, PhotoTimesFromExif) {
  const TempDir dir;
  write_photo_with_time(dir / "zoned.jpg", "2026:06:21 09:30:00", "+09:00");
  write_photo_with_time(dir / "plain.jpg", "2026:06:21 09:30:00", "");
  EXPECT_EQ(skylit::sky::format_utc(skylit::calib::photo_time(dir / "zoned.jpg", "")), "2026-06-21T00:30:00Z");
  // The camera's own zone wins over --utc-offset.
  EXPECT_EQ(skylit::sky::format_utc(skylit::calib::photo_time(dir / "zoned.jpg", "Z")), "2026-06-21T00:30:00Z");
  EXPECT_EQ(skylit::sky::format_utc(skylit::calib::photo_time(dir / "plain.jpg", "-05:00")), "2026-06-21T14:30:00Z");
  try {
    skylit::calib::photo_time(dir / "plain.jpg", "");
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--utc-offset"), std::string::npos) << e.what();
  }
  // A photo without EXIF (the chessboard photos have none).
  try {
    skylit::calib::photo_time(fs::path(SKYLIT_SOURCE_DIR) / "data" / "chessboard" / "left01.jpg", "Z");
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--frames"), std::string::npos) << e.what();
  }
}

TEST(SunFrames, RecoversTheOrientationFromRenderedFrames) {
  const TempDir dir;
  skylit::camera::CameraCalibration truth = skylit::calib_test::small_sky_camera(320);
  truth.R_site_from_camera = true_orientation();
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), truth, kLatitude, kLongitude, day_times(6, 90), true);

  skylit::camera::CameraCalibration intrinsics = truth;
  intrinsics.R_site_from_camera.setIdentity();
  const auto frames = skylit::calib::read_frame_list(csv);
  const auto suns = skylit::calib::find_sun(intrinsics, frames, kLatitude, kLongitude);
  ASSERT_EQ(suns.size(), 6u);
  const skylit::camera::Lens lens(truth);
  for (const auto& s : suns) {
    ASSERT_TRUE(s.observation) << s.frame.file << ": " << s.reason;
    // Found within a pixel (0.56° here) of where the true lens images the sun.
    const auto expected = lens.site_to_pixel(s.solar.direction());
    ASSERT_TRUE(expected && s.pixel);
    EXPECT_LT((*expected - *s.pixel).norm(), 1.0) << s.frame.file;
  }
  const auto observations = skylit::calib::observations_of(suns);
  const skylit::calib::OrientationFit fit = skylit::calib::fit_orientation(observations);
  const double error = skylit::calib::rotation_difference_deg(fit.R_site_from_camera, truth.R_site_from_camera);
  EXPECT_LT(error, 0.5);
  EXPECT_EQ(fit.inliers, 6);
  std::printf("sun frames: orientation %.3f° from the truth, residual RMS %.3f°, sun path %.1f°\n", error, fit.rms_deg,
              fit.spread_deg);

  skylit::camera::CameraCalibration oriented = intrinsics;
  oriented.R_site_from_camera = fit.R_site_from_camera;
  const cv::Mat picture = skylit::calib::draw_orientation(oriented, cv::Mat(), suns, fit.inlier);
  EXPECT_EQ(picture.size(), cv::Size(320, 320));
  EXPECT_GT(cv::countNonZero(picture.reshape(1)), 100) << "the horizon, compass and suns are drawn";
}

TEST(SunFrames, OvercastFramesHaveNoSunAndWrongZonesAreFlagged) {
  const TempDir dir;
  skylit::camera::CameraCalibration truth = skylit::calib_test::small_sky_camera(160);
  const auto times = day_times(2, 120);
  const fs::path overcast = skylit::calib_test::write_sky_frames(dir.path(), truth, kLatitude, kLongitude, times, false);
  for (const auto& s : skylit::calib::find_sun(truth, skylit::calib::read_frame_list(overcast), kLatitude, kLongitude)) {
    EXPECT_FALSE(s.observation);
    EXPECT_EQ(s.reason.rfind("no sun found: ", 0), 0u) << s.reason;
  }
  // Frames taken at 06:00 and 08:00 local time (+09:00) whose zone was written as −09:00: the
  // sun is found, but at the times given (midnight and 02:00 local) it is below the horizon.
  const TempDir other;
  const std::vector<std::chrono::sys_seconds> morning{skylit::sky::parse_utc("2026-06-21T06:00:00+09:00"),
                                                      skylit::sky::parse_utc("2026-06-21T08:00:00+09:00")};
  const fs::path wrong_zone = skylit::calib_test::write_sky_frames(other.path(), truth, kLatitude, kLongitude, morning, true,
                                                                   {"2026-06-21T06:00:00-09:00", "2026-06-21T08:00:00-09:00"});
  for (const auto& s : skylit::calib::find_sun(truth, skylit::calib::read_frame_list(wrong_zone), kLatitude, kLongitude)) {
    EXPECT_FALSE(s.observation);
    EXPECT_TRUE(s.pixel);
    EXPECT_NE(s.reason.find("check the time and its zone"), std::string::npos) << s.reason;
  }
}

TEST(SunFrames, AFrameOfAnotherSizeIsAnError) {
  const TempDir dir;
  const skylit::camera::CameraCalibration camera = skylit::calib_test::small_sky_camera(96);
  const fs::path csv = skylit::calib_test::write_sky_frames(dir.path(), camera, kLatitude, kLongitude, day_times(1, 60), true);
  try {
    skylit::calib::find_sun(skylit::calib_test::small_sky_camera(128), skylit::calib::read_frame_list(csv), kLatitude,
                            kLongitude);
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the frame is 96x96, the calibration 128x128"), std::string::npos) << e.what();
  }
}

}  // namespace
