// The sky simulator as a frame source: the sun where solar_position puts it through the
// calibration, frame times, 8-bit exposures and brackets, equirect skies.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/sources.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/solar.hpp"

namespace {

using namespace skylit::capture;
using skylit::capture::testing::TempDir;
namespace fs = std::filesystem;
namespace camera = skylit::camera;
namespace sky = skylit::sky;

// A 128 × 128 equidistant fisheye at the zenith whose 180° circle (radius 40·π/2 = 62.8 px)
// fills the image: small enough to render in milliseconds.
fs::path write_calibration(const TempDir& dir) {
  return dir.write("sky_camera.yaml",
                   "image_width: 128\nimage_height: 128\nmodel: fisheye\nfx: 40\nfy: 40\ncx: 63.5\ncy: 63.5\n"
                   "D: [0, 0, 0, 0]\nR_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n");
}

SkySimSettings clear_sky(const fs::path& calibration) {
  SkySimSettings s;
  s.calibration = calibration;
  s.sky = SkySimSettings::Sky::Clear;
  s.start = sky::parse_utc("2026-06-21T00:00:00Z");  // 09:00 in Nara
  s.step = std::chrono::hours(2);
  s.frames = 3;
  s.latitude_deg = 34.68;
  s.longitude_deg = 135.84;
  s.supersample = 1;
  return s;
}

cv::Point brightest(const cv::Mat& image) {
  cv::Mat channels[3];
  cv::split(image, channels);
  cv::Point where;
  cv::minMaxLoc(channels[1], nullptr, nullptr, nullptr, &where);
  return where;
}

TEST(SkySimSource, TheSunIsWhereSolarPositionPutsItThroughTheCalibration) {
  TempDir dir;
  const fs::path calibration = write_calibration(dir);
  SkySimSource source(clear_sky(calibration));
  const camera::Lens lens(camera::load_calibration(calibration));
  for (int k = 0; k < 3; ++k) {
    FrameResult result = source.next(0);
    ASSERT_EQ(result.status, FrameStatus::Ready) << k;
    const Frame& frame = result.frame;
    EXPECT_EQ(frame.image.type(), CV_32FC3);
    EXPECT_EQ(frame.image.size(), cv::Size(128, 128));
    EXPECT_DOUBLE_EQ(frame.timestamp, 7200.0 * k);
    ASSERT_TRUE(frame.utc.has_value());
    EXPECT_EQ(*frame.utc, sky::parse_utc("2026-06-21T00:00:00Z") + std::chrono::hours(2 * k));
    EXPECT_FALSE(frame.exposure_time.has_value()) << "float frames are radiance";

    const sky::SolarPosition sun = sky::solar_position(*frame.utc, 34.68, 135.84);
    ASSERT_GT(sun.elevation_rad, 0.3) << "the sun is up in the morning in June";
    const auto expected = lens.site_to_pixel(sun.direction());
    ASSERT_TRUE(expected.has_value());
    const cv::Point peak = brightest(frame.image);
    // The sun's disc lands in the pixel holding its centre: within half a pixel's diagonal.
    EXPECT_LE(std::hypot(peak.x - expected->x(), peak.y - expected->y()), 0.75)
        << "frame " << k << ": peak (" << peak.x << ", " << peak.y << "), sun at (" << expected->x() << ", "
        << expected->y() << ")";
  }
  EXPECT_EQ(source.next(0).status, FrameStatus::EndOfStream);
}

TEST(SkySimSource, ExposureGivesCameraLikeEightBitFramesAndBrackets) {
  TempDir dir;
  const fs::path calibration = write_calibration(dir);
  SkySimSource reference(clear_sky(calibration));
  const cv::Mat radiance = reference.next(0).frame.image;

  SkySimSource source(clear_sky(calibration));
  const double times[] = {0.005, 0.05, 0.5};
  std::optional<std::vector<Frame>> bracket = source.bracket(times, 1.0);
  ASSERT_TRUE(bracket.has_value());
  ASSERT_EQ(bracket->size(), 3u);
  double previous_mean = -1;
  for (std::size_t i = 0; i < 3; ++i) {
    const Frame& frame = (*bracket)[i];
    EXPECT_EQ(frame.image.type(), CV_8UC3);
    ASSERT_TRUE(frame.exposure_time.has_value());
    EXPECT_DOUBLE_EQ(*frame.exposure_time, times[i]);
    EXPECT_DOUBLE_EQ(frame.timestamp, 0.0) << "a bracket shows one sky";
    EXPECT_EQ(cv::norm(frame.image, sky::to_8bit(radiance, times[i]), cv::NORM_INF), 0.0);
    const double mean = cv::mean(frame.image)[1];
    EXPECT_GT(mean, previous_mean);
    previous_mean = mean;
  }
  // The next frame is the next sky time, at the exposure and gain set.
  EXPECT_TRUE(source.set_exposure_time(0.02));
  EXPECT_TRUE(source.set_gain(2.0));
  FrameResult next = source.next(0);
  ASSERT_EQ(next.status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(next.frame.timestamp, 7200.0);
  EXPECT_EQ(next.frame.image.type(), CV_8UC3);
  const cv::Mat radiance1 = reference.next(0).frame.image;
  EXPECT_EQ(cv::norm(next.frame.image, sky::to_8bit(radiance1, 0.04), cv::NORM_INF), 0.0);
  EXPECT_FALSE(source.set_exposure_time(-1.0));
}

TEST(SkySimSource, AnEquirectSkyIsRenderedOnceAndRepeated) {
  TempDir dir;
  const fs::path calibration = write_calibration(dir);
  const cv::Mat equirect = sky::render_equirect(sky::sky_function(sky::OvercastSky(5.0)), 64, 32);
  const fs::path file = dir.path() / "overcast.exr";
  sky::write_sky_exr(file, equirect);

  SkySimSettings settings;
  settings.calibration = calibration;
  settings.sky = SkySimSettings::Sky::Equirect;
  settings.equirect = file;
  settings.azimuth_offset_deg = 30;
  settings.step = std::chrono::seconds(10);
  settings.supersample = 1;
  SkySimSource source(settings);
  sky::RenderOptions options;
  options.supersample = 1;
  options.azimuth_offset = 30 * std::numbers::pi / 180;
  const cv::Mat expected = sky::render_fisheye(camera::Lens(camera::load_calibration(calibration)),
                                               sky::read_equirect(file), options);
  for (int k = 0; k < 3; ++k) {
    FrameResult result = source.next(0);
    ASSERT_EQ(result.status, FrameStatus::Ready);
    EXPECT_DOUBLE_EQ(result.frame.timestamp, 10.0 * k);
    EXPECT_FALSE(result.frame.utc.has_value());
    EXPECT_EQ(cv::norm(result.frame.image, expected, cv::NORM_INF), 0.0);
  }
  // The overcast sky's zenith: 5 at the image centre, within the equirect's sampling.
  EXPECT_NEAR(expected.at<cv::Vec3f>(63, 63)[1], 5.0, 0.1);
}

TEST(SkySimSource, BadSettingsAreInputErrors) {
  TempDir dir;
  const fs::path calibration = write_calibration(dir);
  SkySimSettings settings = clear_sky(calibration);
  settings.calibration = dir.path() / "missing.yaml";
  EXPECT_THROW(SkySimSource{settings}, skylit::InputError);
  settings = clear_sky(calibration);
  settings.supersample = 0;
  EXPECT_THROW(SkySimSource{settings}, skylit::InputError);
  settings = clear_sky(calibration);
  settings.turbidity = 20;
  EXPECT_THROW(SkySimSource{settings}, skylit::InputError);
  settings = clear_sky(calibration);
  settings.sky = SkySimSettings::Sky::Equirect;
  settings.equirect = dir.path() / "missing.exr";
  try {
    SkySimSource source(settings);
    FAIL() << "no error for a missing equirect";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.exr"), std::string::npos) << e.what();
  }
}

TEST(SkySimShared, IntervalsParseAsSkylitSkyDoes) {
  EXPECT_EQ(sky::parse_interval("30min"), std::chrono::minutes(30));
  EXPECT_EQ(sky::parse_interval("1.5h"), std::chrono::seconds(5400));
  EXPECT_EQ(sky::parse_interval(" 90 s "), std::chrono::seconds(90));
  EXPECT_THROW(sky::parse_interval("often"), skylit::InputError);
  EXPECT_THROW(sky::parse_interval("0.5s"), skylit::InputError);
}

}  // namespace
