// Sun detection: found where a compact sun is, absent where none is, energy and direction right.
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../support/sky_paint.hpp"
#include "skylit/base/error.hpp"

#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/sun.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace sun_test {  // named, not anonymous: the test program is one unity build

constexpr double kDeg = std::numbers::pi / 180.0;

// Like the sample sky camera: equidistant fisheye looking at the zenith, image x towards east.
camera::CameraCalibration zenith_camera(int size = 512) {
  camera::CameraCalibration c;
  c.image_width = size;
  c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = (size / 2.0) / (std::numbers::pi / 2.0);  // 90° at the edge of the circle
  c.cx = c.cy = (size - 1) / 2.0;
  c.D = {0, 0, 0, 0};
  c.R_site_from_camera = Eigen::Matrix3d::Identity();  // camera z up, image x east, image y north
  return c;
}

using skylit::test::angle;
using skylit::test::from_angles;

// Paints every pixel with radiance(direction) (RGB), 0 where the lens sees nothing.
cv::Mat paint(const camera::Lens& lens, const std::function<Eigen::Vector3d(const Vec3&)>& radiance) {
  return skylit::test::paint_sky(lens, radiance);
}


// A clear-ish sky (brighter towards the horizon and around the sun) with a disc.
struct DiscSky {
  Vec3 sun;
  double radius;          // radians
  Eigen::Vector3d disc;   // radiance inside the disc
  Eigen::Vector3d operator()(const Vec3& d) const {
    if (d.z() < 0) return Eigen::Vector3d(0.2, 0.2, 0.2);
    const Eigen::Vector3d sky = Eigen::Vector3d(0.5, 0.7, 1.0) * (1.0 + 0.5 * (1.0 - d.z()));
    return angle(d, sun) <= radius ? disc : sky;
  }
};

TEST(SunDetector, BlackSkyHasNoSun) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  const cv::Mat black(512, 512, CV_32FC3, cv::Scalar(0, 0, 0));
  const SunDetection d = detector.detect(black, cv::Mat());
  EXPECT_FALSE(d.sun);
  EXPECT_NE(d.reason.find("black"), std::string::npos) << d.reason;
  EXPECT_TRUE(d.mask.empty());
}

TEST(SunDetector, OvercastSkyHasNoSun) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  // CIE overcast: zenith three times the horizon, no compact source.
  const cv::Mat overcast = paint(lens, [](const Vec3& d) {
    return Eigen::Vector3d::Constant(d.z() < 0 ? 0.0 : (1.0 + 2.0 * d.z()) / 3.0);
  });
  const SunDetection d = detector.detect(overcast, cv::Mat());
  EXPECT_FALSE(d.sun);
  EXPECT_NE(d.reason.find("no compact sun"), std::string::npos) << d.reason;
}

TEST(SunDetector, FindsADiscWithItsDirectionAndEnergy) {
  const camera::Lens lens(zenith_camera(1024));
  const SunDetector detector(lens, cv::Mat());
  const DiscSky sky{from_angles(135.0, 40.0), 1.0 * kDeg, Eigen::Vector3d(8000, 7000, 6000)};
  const cv::Mat frame = paint(lens, sky);
  const SunDetection d = detector.detect(frame, cv::Mat());
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_LT(angle(d.sun->direction, sky.sun), 0.05 * kDeg);
  // E = L_disc · solid angle of the disc (minus the background it hides), within pixelisation.
  const double disc_solid_angle = 2.0 * std::numbers::pi * (1.0 - std::cos(sky.radius));
  const Eigen::Vector3d background = sky(from_angles(135.0, 40.0 + 10.0));
  for (int c = 0; c < 3; ++c) {
    const double expected = (sky.disc[c] - d.sun->background[c]) * disc_solid_angle;
    EXPECT_NEAR(d.sun->energy[c], expected, 0.03 * expected) << "channel " << c;
    EXPECT_NEAR(d.sun->background[c], background[c], 0.1 * background[c]);
  }
  EXPECT_NEAR(d.sun->angular_radius, sky.radius, 0.3 * kDeg);
  // A uniform disc's shadow radius (its pixels' second moment) is its radius, within pixelisation.
  EXPECT_NEAR(d.sun->shadow_radius, sky.radius, 0.15 * kDeg);
  EXPECT_FALSE(d.sun->clipped);
  // The mask covers the disc's pixels, no more.
  EXPECT_EQ(cv::countNonZero(d.mask), d.sun->pixel_count);
  const auto centre = lens.site_to_pixel(sky.sun);
  ASSERT_TRUE(centre);
  EXPECT_EQ(d.mask.at<std::uint8_t>(static_cast<int>(std::lround(centre->y())), static_cast<int>(std::lround(centre->x()))), 255);
}

// An extended lamp (a bright tube 8° long and 1° wide, brightest at its middle): its core radius
// reaches towards its ends, but its shadows are as soft as a disc of its spread; the shadow
// radius is that disc's (√2 × the energy-weighted RMS angle, here integrated on a fine grid).
TEST(SunDetector, AnExtendedLampsShadowRadiusMatchesItsSpread) {
  const camera::Lens lens(zenith_camera(1024));
  const SunDetector detector(lens, cv::Mat(), lamp_options());
  const Vec3 centre = from_angles(90.0, 60.0);
  const Vec3 along = Vec3::UnitZ().cross(centre).normalized();  // horizontal, across the azimuth
  const Vec3 across = centre.cross(along);
  const double half_length = 4.0 * kDeg, half_width = 0.5 * kDeg;
  const auto tube = [&](double u, double v) {  // radiance over the background of 1
    if (std::abs(u) > half_length || std::abs(v) > half_width) return 0.0;
    return 500.0 * (1.0 - 0.5 * (u / half_length) * (u / half_length));
  };
  const cv::Mat frame = paint(lens, [&](const Vec3& d) -> Eigen::Vector3d {
    if (d.z() < 0) return Eigen::Vector3d::Zero();
    const double u = std::atan2(d.dot(along), d.dot(centre)), v = std::atan2(d.dot(across), d.dot(centre));
    return Eigen::Vector3d::Constant(1.0 + tube(u, v));
  });
  double second = 0, total = 0;
  for (int i = -400; i <= 400; ++i) {
    for (int j = -50; j <= 50; ++j) {
      const double u = i * half_length / 400, v = j * half_width / 50, w = tube(u, v);
      second += w * (u * u + v * v);
      total += w;
    }
  }
  const double expected = std::sqrt(2.0 * second / total);  // about 2.9°
  const SunDetection d = detector.detect(frame, cv::Mat());
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_NEAR(d.sun->shadow_radius, expected, 0.1 * expected);
  EXPECT_GT(d.sun->angular_radius, d.sun->shadow_radius) << "the core reaches towards the tube's ends";
}

// A glow around the disc (1°–3°, 5× the sky) fainter than disc_factor × the background stays
// in the dome (sharp sun shadows); a lower disc_factor takes it into the sun term.
TEST(SunDetector, GlowFainterThanTheDiscFactorStaysInTheDome) {
  const camera::Lens lens(zenith_camera(1024));
  const DiscSky disc_sky{from_angles(135.0, 40.0), 1.0 * kDeg, Eigen::Vector3d(8000, 7000, 6000)};
  const auto sky = [&](const Vec3& d) -> Eigen::Vector3d {
    const double a = angle(d, disc_sky.sun);
    if (d.z() >= 0 && a > disc_sky.radius && a <= 3.0 * kDeg) return 5.0 * disc_sky(d);
    return disc_sky(d);
  };
  const cv::Mat frame = paint(lens, sky);
  const double disc_solid_angle = 2.0 * std::numbers::pi * (1.0 - std::cos(disc_sky.radius));
  const double glow_solid_angle = 2.0 * std::numbers::pi * (std::cos(disc_sky.radius) - std::cos(3.0 * kDeg));

  const SunDetection tight = SunDetector(lens, cv::Mat()).detect(frame, cv::Mat());
  ASSERT_TRUE(tight.sun) << tight.reason;
  ASSERT_EQ(SunOptions{}.disc_factor, 10.0);
  for (int c = 0; c < 3; ++c) {
    const double expected = (disc_sky.disc[c] - tight.sun->background[c]) * disc_solid_angle;
    EXPECT_NEAR(tight.sun->energy[c], expected, 0.03 * expected) << "channel " << c;
  }
  for (const Vec3& d : tight.sun->disc_directions) EXPECT_LT(angle(d, disc_sky.sun), disc_sky.radius + 0.3 * kDeg);

  SunOptions wide_options;
  wide_options.disc_factor = 3.0;
  const SunDetection wide = SunDetector(lens, cv::Mat(), wide_options).detect(frame, cv::Mat());
  ASSERT_TRUE(wide.sun) << wide.reason;
  EXPECT_GT(wide.sun->pixel_count, 4 * tight.sun->pixel_count);
  for (int c = 0; c < 3; ++c) {
    // The glow's excess over the background joins the sun: 4 × the sky over the glow's area.
    const double glow = (5.0 - 1.0) * wide.sun->background[c] * glow_solid_angle;
    EXPECT_NEAR(wide.sun->energy[c] - tight.sun->energy[c], glow, 0.15 * glow) << "channel " << c;
  }
}

TEST(SunDetector, ARealSizedSunOfAFewPixels) {
  const camera::Lens lens(zenith_camera(1024));
  const SunDetector detector(lens, cv::Mat());
  const DiscSky sky{from_angles(200.0, 55.0), 0.27 * kDeg, Eigen::Vector3d(1e5, 1e5, 1e5)};
  const SunDetection d = detector.detect(paint(lens, sky), cv::Mat());
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_LT(angle(d.sun->direction, sky.sun), 0.1 * kDeg);
  EXPECT_LE(d.sun->pixel_count, 20);
}

TEST(SunDetector, OnlyTheSunInABlackSky) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  const Vec3 sun = from_angles(10.0, 70.0);
  const cv::Mat frame = paint(lens, [&](const Vec3& d) {
    return Eigen::Vector3d::Constant(angle(d, sun) <= 0.8 * kDeg ? 1e4 : 0.0);
  });
  const SunDetection d = detector.detect(frame, cv::Mat());
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_TRUE(std::isinf(d.sun->contrast));
  EXPECT_LT(angle(d.sun->direction, sun), 0.1 * kDeg);
  EXPECT_GT(d.sun->energy.minCoeff(), 0.0);
}

TEST(SunDetector, ABroadBrightPatchIsNoCompactSun) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  const DiscSky sky{from_angles(90.0, 45.0), 8.0 * kDeg, Eigen::Vector3d(500, 500, 500)};
  const SunDetection d = detector.detect(paint(lens, sky), cv::Mat());
  EXPECT_FALSE(d.sun);
  EXPECT_NE(d.reason.find("wider"), std::string::npos) << d.reason;
}

TEST(SunDetector, SunBelowTheHorizonIsNotFound) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  const DiscSky sky{from_angles(270.0, -3.0), 0.5 * kDeg, Eigen::Vector3d(1e4, 1e4, 1e4)};
  const SunDetection d = detector.detect(paint(lens, sky), cv::Mat());
  EXPECT_FALSE(d.sun) << "found a sun at elevation " << std::asin(d.sun->direction.z()) / kDeg;
}

TEST(SunDetector, SunOnTheHorizonIsFoundAboveIt) {
  const camera::Lens lens(zenith_camera(1024));
  const SunDetector detector(lens, cv::Mat());
  const DiscSky sky{from_angles(270.0, 0.0), 0.5 * kDeg, Eigen::Vector3d(1e4, 1e4, 1e4)};
  const SunDetection d = detector.detect(paint(lens, sky), cv::Mat());
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_GE(d.sun->direction.z(), 0.0);
  EXPECT_LT(angle(d.sun->direction, sky.sun), 0.5 * kDeg);
}

TEST(SunDetector, AClippedSunIsFoundAndSaysSo) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  // An 8-bit frame: the sky at half the top code, the sun clipped (contrast only 2).
  const Vec3 sun = from_angles(45.0, 50.0);
  const cv::Mat frame = paint(lens, [&](const Vec3& d) {
    return Eigen::Vector3d::Constant(angle(d, sun) <= 1.0 * kDeg ? 1.0 : 0.5);
  });
  cv::Mat clipped(frame.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      if (frame.at<cv::Vec3f>(y, x)[1] >= 1.0f) clipped.at<std::uint8_t>(y, x) = 255;
    }
  }
  const SunDetection d = detector.detect(frame, clipped);
  ASSERT_TRUE(d.sun) << d.reason;
  EXPECT_TRUE(d.sun->clipped);
  EXPECT_NE(d.reason.find("lower bound"), std::string::npos) << d.reason;
  EXPECT_LT(angle(d.sun->direction, sun), 0.2 * kDeg);
}

TEST(SunDetector, BadPixelsNeverBecomeTheSun) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  cv::Mat frame = paint(lens, [](const Vec3& d) { return Eigen::Vector3d::Constant(d.z() < 0 ? 0.0 : 1.0); });
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  frame.at<cv::Vec3f>(256, 256) = cv::Vec3f(nan, nan, nan);
  frame.at<cv::Vec3f>(200, 300) = cv::Vec3f(inf, inf, inf);
  frame.at<cv::Vec3f>(300, 200) = cv::Vec3f(-1e9f, -1e9f, -1e9f);
  const SunDetection d = detector.detect(frame, cv::Mat());
  EXPECT_FALSE(d.sun) << d.reason;
}

TEST(SunDetector, MaskedPixelsAreNotSearched) {
  const camera::Lens lens(zenith_camera());
  cv::Mat mask(512, 512, CV_8UC1, cv::Scalar(255));
  const DiscSky sky{from_angles(90.0, 30.0), 0.8 * kDeg, Eigen::Vector3d(1e4, 1e4, 1e4)};
  const auto p = lens.site_to_pixel(sky.sun);
  ASSERT_TRUE(p);
  cv::circle(mask, cv::Point(static_cast<int>(p->x()), static_cast<int>(p->y())), 30, cv::Scalar(0), -1);
  const SunDetector detector(lens, mask);
  EXPECT_FALSE(detector.detect(paint(lens, sky), cv::Mat()).sun);
}

TEST(SunDetector, WrongFrameSizeIsAnInputError) {
  const camera::Lens lens(zenith_camera());
  const SunDetector detector(lens, cv::Mat());
  EXPECT_THROW(detector.detect(cv::Mat(100, 100, CV_32FC3, cv::Scalar(0, 0, 0)), cv::Mat()), InputError);
  EXPECT_THROW(detector.detect(cv::Mat(512, 512, CV_8UC3, cv::Scalar(0, 0, 0)), cv::Mat()), InputError);
}

}  // namespace
}  // namespace skylit::sky
