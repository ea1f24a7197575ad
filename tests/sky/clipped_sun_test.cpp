// A sun through an 8-bit camera: an analytic clear sky exposed as one metered 8-bit frame clips
// the sun into a blob degrees wide. It is found where the location and time put it, or by the
// blob's round shape without them; a clipped band (a bright cloud's edge) is not a sun; and the
// clear-sky fit recovers the sky's turbidity and the sun's energy from the unclipped sky, with
// no confidence under an overcast sky.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/sky/clear_sky_fit.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sun.hpp"

namespace skylit::sky {
namespace clipped_sun_test {  // named: the test program is one unity build

constexpr double kDeg = std::numbers::pi / 180.0;

camera::CameraCalibration zenith_camera(int size = 384) {
  camera::CameraCalibration c;
  c.image_width = c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = (size / 2.0) / (std::numbers::pi / 2.0);
  c.cx = c.cy = (size - 1) / 2.0;
  c.D = {0, 0, 0, 0};
  c.R_site_from_camera = Eigen::Matrix3d::Identity();
  return c;
}

Vec3 sun_at(double elevation_deg, double azimuth_deg) {
  const double el = elevation_deg * kDeg, az = azimuth_deg * kDeg;
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

double degrees(const Vec3& a, const Vec3& b) { return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) / kDeg; }

// Every pixel that sees the sky, as the detector takes it.
cv::Mat sky_of(const camera::Lens& lens) { return SunDetector(lens, cv::Mat()).sky().clone(); }

// The sky as one 8-bit frame metered to put its median at `fraction` of full scale, read back.
RadianceFrame eight_bit(const camera::Lens& lens, const cv::Mat& radiance, double fraction) {
  const double scale = auto_exposure_scale(radiance, sky_of(lens), fraction);
  return linearise(to_8bit(radiance, scale), ResponseCurve::srgb(8), Exposure{scale, 1.0});
}

// The clear sky with an aureole, as real skies have around the sun (Preetham's has little): what
// makes a metered 8-bit camera clip degrees around the sun.
SkyFunction with_aureole(const ClearSky& sky) {
  SkyFunction f = sky_function(sky);
  const Vec3 sun = sky.sun_direction();
  const Eigen::Vector3d zenith = sky.sky_radiance(Vec3::UnitZ());
  const auto plain = f.sky;
  f.sky = [plain, sun, zenith](const Vec3& d) {
    const double gamma = std::acos(std::clamp(d.normalized().dot(sun), -1.0, 1.0));
    return Eigen::Vector3d(plain(d) + 15.0 * zenith * std::exp(-gamma / (1.5 * kDeg)));
  };
  return f;
}

struct ClearFrame {
  camera::Lens lens{zenith_camera()};
  Vec3 sun = sun_at(40.0, 120.0);
  ClearSky sky{sun, 3.0};
  cv::Mat hdr = render_fisheye(lens, with_aureole(sky), {.supersample = 2});
  RadianceFrame frame = eight_bit(lens, hdr, 0.18);
};

const ClearFrame& clear_frame() {
  static const ClearFrame frame;
  return frame;
}

TEST(ClippedSun, AMeteredEightBitFrameClipsTheSunIntoAWideBlob) {
  const ClearFrame& f = clear_frame();
  const int clipped = cv::countNonZero(f.frame.clipped);
  EXPECT_GT(clipped, 12) << "more than the sun's own pixel or two";
  const SunDetector detector(f.lens, cv::Mat());
  // The standard detector's answer for this frame, whatever it is, says the sun is clipped.
  const SunDetection found = detector.detect(f.frame.radiance, f.frame.clipped);
  ASSERT_TRUE(found.sun.has_value()) << found.reason;
  EXPECT_TRUE(found.sun->clipped);
}

TEST(ClippedSun, FoundWhereTheLocationAndTimePutItAndByItsShapeWithoutThem) {
  const ClearFrame& f = clear_frame();
  SunOptions narrow;  // a core no wider than the camera's own pixel: every clipped blob is "too wide"
  narrow.max_angular_radius_deg = 0.3;
  const SunDetector detector(f.lens, cv::Mat(), narrow);
  const SunDetection expected = detector.detect(f.frame.radiance, f.frame.clipped, f.sun);
  ASSERT_TRUE(expected.sun.has_value()) << expected.reason;
  EXPECT_EQ(expected.sun->located_by, "expected");
  EXPECT_LT(degrees(expected.sun->direction, f.sun), 1e-9);
  EXPECT_TRUE(expected.sun->clipped);
  EXPECT_NEAR(expected.sun->shadow_radius, kSunAngularRadius, 1e-12) << "shadows take the sun's disc, not the blob";
  EXPECT_EQ(expected.sun->disc_directions.size(), 1u);

  const SunDetection shape = detector.detect(f.frame.radiance, f.frame.clipped);
  ASSERT_TRUE(shape.sun.has_value()) << shape.reason;
  EXPECT_EQ(shape.sun->located_by, "clipped shape");
  EXPECT_LT(degrees(shape.sun->direction, f.sun), 1.0);

  // An expectation 30° away from any clipped pixel finds no blob there: the frame's own peak decides.
  const SunDetection elsewhere = detector.detect(f.frame.radiance, f.frame.clipped, sun_at(40.0, 160.0));
  EXPECT_FALSE(elsewhere.sun && elsewhere.sun->located_by == "expected");
}

TEST(ClippedSun, AClippedBandIsNoSunWithoutAnExpectation) {
  const camera::Lens lens(zenith_camera());
  // A bright cloud edge: a band 3° wide and 24° long, clipped, on a plain sky.
  cv::Mat radiance(lens.calibration().image_height, lens.calibration().image_width, CV_32FC3, cv::Scalar(0.3, 0.3, 0.3));
  cv::Mat clipped(radiance.size(), CV_8UC1, cv::Scalar(0));
  const Vec3 centre = sun_at(45.0, 90.0);
  const Vec3 along = centre.cross(Vec3::UnitZ()).normalized();
  for (int y = 0; y < radiance.rows; ++y) {
    for (int x = 0; x < radiance.cols; ++x) {
      const auto d = lens.pixel_to_site(Eigen::Vector2d(x, y));
      if (!d || d->z() < 0) continue;
      const Vec3 across = centre.cross(along).normalized();
      if (std::abs(std::asin(d->dot(across))) < 1.5 * kDeg && std::abs(std::asin(d->dot(along))) < 12 * kDeg && d->dot(centre) > 0) {
        radiance.at<cv::Vec3f>(y, x) = cv::Vec3f(1, 1, 1);
        clipped.at<std::uint8_t>(y, x) = 255;
      }
    }
  }
  SunOptions options;
  options.max_clipped_radius_deg = 25.0;  // so that its shape, not its width, decides
  const SunDetector detector(lens, cv::Mat(), options);
  const SunDetection found = detector.detect(radiance, clipped);
  EXPECT_FALSE(found.sun.has_value()) << found.reason;
  EXPECT_NE(found.reason.find("round"), std::string::npos) << found.reason;
}

TEST(ClearSkyFit, RecoversTheTurbidityAndTheSunsEnergyFromTheUnclippedSky) {
  const ClearFrame& f = clear_frame();
  const std::optional<ClearSkyFit> fit =
      fit_clear_sky(f.lens, sky_of(f.lens), f.frame.radiance, f.frame.clipped, cv::Mat(), f.sun);
  ASSERT_TRUE(fit.has_value());
  EXPECT_NEAR(fit->turbidity, 3.0, 0.5);
  EXPECT_LT(fit->residual, 0.05) << "the model is the sky (8-bit rounding aside)";
  EXPECT_GT(fit->confidence, 0.8);
  const double truth = rgb_luminance(f.sky.sun().irradiance);
  EXPECT_NEAR(rgb_luminance(fit->sun_energy), truth, 0.1 * truth);

  // The sky stage: the measured (clipped) energy is far below the truth, the estimate near it.
  SkyEstimateOptions options;
  options.sun.max_angular_radius_deg = 0.3;
  const geom::Dome dome(2);
  options.clipped_sun_energy = ClippedSunEnergy::Measured;
  const SkyEstimate measured = SkyEstimator(f.lens.calibration(), dome, options).estimate(f.frame, f.sun);
  options.clipped_sun_energy = ClippedSunEnergy::ClearSky;
  const SkyEstimate estimated = SkyEstimator(f.lens.calibration(), dome, options).estimate(f.frame, f.sun);
  ASSERT_TRUE(measured.sun && estimated.sun);
  EXPECT_LT(rgb_luminance(measured.sun->energy), 0.5 * truth);
  EXPECT_EQ(measured.sun->energy_estimator, "measured");
  EXPECT_EQ(estimated.sun->energy_estimator, "clear_sky");
  EXPECT_NEAR(rgb_luminance(estimated.sun->energy), truth, 0.2 * truth);
}

TEST(ClearSkyFit, AnOvercastSkyGivesNoConfidence) {
  const camera::Lens lens(zenith_camera());
  const cv::Mat hdr = render_fisheye(lens, sky_function(OvercastSky(5.0)), {.supersample = 1});
  const std::optional<ClearSkyFit> fit = fit_clear_sky(lens, sky_of(lens), hdr, cv::Mat(), cv::Mat(), sun_at(40.0, 120.0));
  ASSERT_TRUE(fit.has_value());
  EXPECT_GT(fit->residual, 0.2);
  EXPECT_LT(fit->confidence, 0.5);
  EXPECT_FALSE(fit_clear_sky(lens, sky_of(lens), hdr, cv::Mat(), cv::Mat(), sun_at(-5.0, 120.0)).has_value())
      << "a sun below the horizon has no clear-sky sun";
}

TEST(AutoExposure, TheSkysMedianLandsAtTheFraction) {
  const ClearFrame& f = clear_frame();
  const cv::Mat sky = sky_of(f.lens);
  const double scale = auto_exposure_scale(f.hdr, sky, 0.18);
  std::vector<double> values;
  for (int y = 0; y < sky.rows; ++y) {
    for (int x = 0; x < sky.cols; ++x) {
      if (!sky.at<std::uint8_t>(y, x)) continue;
      const cv::Vec3f p = f.hdr.at<cv::Vec3f>(y, x);
      values.push_back(scale * (0.0722 * p[0] + 0.7152 * p[1] + 0.2126 * p[2]));
    }
  }
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2), values.end());
  EXPECT_NEAR(values[values.size() / 2], 0.18, 1e-9);
  EXPECT_THROW(auto_exposure_scale(f.hdr, sky, 0.0), std::invalid_argument);
}

}  // namespace clipped_sun_test
}  // namespace skylit::sky
