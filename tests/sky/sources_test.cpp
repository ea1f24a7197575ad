// Several separated sources (issue 3): the sun test first, then compact lamps one after the
// other (detect → set the disc to its background → detect again), every disc left out of S.
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "../support/sky_paint.hpp"
#include "skylit/base/error.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

camera::CameraCalibration zenith_camera(int size = 400) {
  camera::CameraCalibration c;
  c.image_width = c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = (size / 2.0) / (std::numbers::pi / 2.0);
  c.cx = c.cy = (size - 1) / 2.0;
  c.D = {0, 0, 0, 0};
  c.R_site_from_camera = Eigen::Matrix3d::Identity();
  return c;
}

using skylit::test::angle;
using skylit::test::from_angles;

RadianceFrame paint(const camera::CameraCalibration& c, const std::function<Eigen::Vector3d(const Vec3&)>& radiance) {
  return {skylit::test::paint_sky(camera::Lens(c), radiance), cv::Mat()};
}

// A dim uniform sky with two lamps 4° in radius, brightest at their centres (radiance
// L0 (1 − 0.3 (θ/r)²), so that the detector's peak is the centre and the whole lamp stands over
// 10× the sky): cores 4° wide, too wide for the sun's test (3°), compact for the lamp mode.
const Vec3 kLampA = from_angles(60.0, 50.0);
const Vec3 kLampB = from_angles(250.0, 35.0);
const Eigen::Vector3d kSky(0.1, 0.1, 0.1);
const Eigen::Vector3d kPeakA(2.7, 2.25, 1.8);   // luminance ≈ 2.3 at the centre, 1.6 at the rim
const Eigen::Vector3d kPeakB(1.35, 1.8, 2.25);  // ≈ 1.7, 1.2
constexpr double kLampRadius = 4.0 * kDeg;
Eigen::Vector3d two_lamps(const Vec3& d) {
  if (d.z() < 0) return Eigen::Vector3d::Zero();
  const double a = angle(d, kLampA), b = angle(d, kLampB);
  if (a <= kLampRadius) return kPeakA * (1.0 - 0.3 * (a / kLampRadius) * (a / kLampRadius));
  if (b <= kLampRadius) return kPeakB * (1.0 - 0.3 * (b / kLampRadius) * (b / kLampRadius));
  return kSky;
}

double disc_solid_angle(double radius) { return 2.0 * std::numbers::pi * (1.0 - std::cos(radius)); }

SkyEstimate estimate(const RadianceFrame& frame, int max_sources, SunMode mode = SunMode::Auto) {
  static const geom::Dome dome(2);
  SkyEstimateOptions options;
  options.sun_mode = mode;
  options.max_sources = max_sources;
  const SkyEstimator estimator(zenith_camera(), dome, options);
  return estimator.estimate(frame);
}

int removed_faces(const SkyEstimate& e) {
  int n = 0;
  for (const auto& f : e.luminance.faces) n += (f.flags & kFaceSunRemoved) ? 1 : 0;
  return n;
}

TEST(SeparatedSources, TwoLampsAreBothFoundAndLeftOutOfTheDome) {
  const RadianceFrame frame = paint(zenith_camera(), two_lamps);
  const SkyEstimate e = estimate(frame, 8);
  EXPECT_FALSE(e.sun) << e.sun_reason;  // neither lamp is a sun
  ASSERT_EQ(e.sources.size(), 2u) << e.sources_reason;
  EXPECT_LT(angle(e.sources[0].direction, kLampA), 0.5 * kDeg);  // the brighter first
  EXPECT_LT(angle(e.sources[1].direction, kLampB), 0.5 * kDeg);
  EXPECT_NE(e.sources_reason.find("wider"), std::string::npos) << e.sources_reason;  // the flat sky is no lamp
  // E = ∫ (L − background) over the disc = (0.85 L0 − background) Ω, per channel.
  const double omega = disc_solid_angle(kLampRadius);
  const Eigen::Vector3d a = (0.85 * kPeakA - kSky) * omega;
  const Eigen::Vector3d b = (0.85 * kPeakB - kSky) * omega;
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(e.sources[0].energy[c], a[c], 0.1 * a[c]);
    EXPECT_NEAR(e.sources[1].energy[c], b[c], 0.1 * b[c]);
  }
  EXPECT_NEAR(e.sources[0].background.x(), kSky.x(), 1e-6);
  // Both discs are out of S: every face is the dim sky again.
  EXPECT_GE(removed_faces(e), 2);
  for (const auto& f : e.luminance.faces) {
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.rgb[c], kSky[c], 0.02 * kSky[c]);
  }
}

TEST(SeparatedSources, OneSourceIsTodaysBehaviour) {
  // Lamps: no sun, nothing separated, nothing removed from S (the lamps stay in the dome).
  const RadianceFrame lamps = paint(zenith_camera(), two_lamps);
  const SkyEstimate e = estimate(lamps, 1);
  EXPECT_FALSE(e.sun);
  EXPECT_TRUE(e.sources.empty());
  EXPECT_TRUE(e.sources_reason.empty());
  EXPECT_EQ(removed_faces(e), 0);
  // A sun with a lamp: the sun alone, as before; with more sources the sun stays first.
  const Vec3 sun = from_angles(180.0, 40.0);
  const RadianceFrame sunny = paint(zenith_camera(), [&](const Vec3& d) -> Eigen::Vector3d {
    if (angle(d, sun) <= 0.8 * kDeg) return Eigen::Vector3d::Constant(500.0);
    return two_lamps(d);
  });
  const SkyEstimate one = estimate(sunny, 1);
  ASSERT_TRUE(one.sun) << one.sun_reason;
  ASSERT_EQ(one.sources.size(), 1u);
  EXPECT_EQ(one.sources[0].direction, one.sun->direction);
  const SkyEstimate several = estimate(sunny, 4);
  ASSERT_TRUE(several.sun);
  ASSERT_EQ(several.sources.size(), 3u) << several.sources_reason;
  EXPECT_EQ(several.sources[0].direction, one.sun->direction);
  EXPECT_EQ(several.sources[0].energy, one.sun->energy);
  EXPECT_LT(angle(several.sources[1].direction, kLampA), 0.5 * kDeg);
  EXPECT_LT(angle(several.sources[2].direction, kLampB), 0.5 * kDeg);
  // The sun's S is unchanged where no lamp is.
  for (std::size_t i = 0; i < one.luminance.faces.size(); ++i) {
    if (several.luminance.faces[i].flags & kFaceSunRemoved) continue;
    EXPECT_EQ(one.luminance.faces[i].rgb, several.luminance.faces[i].rgb) << "face " << i;
  }
}

TEST(SeparatedSources, MaxSourcesCapsTheSearch) {
  const SkyEstimate e = estimate(paint(zenith_camera(), two_lamps), 1 + 1);
  ASSERT_EQ(e.sources.size(), 2u);
  EXPECT_EQ(e.sources_reason, "max_sources reached");
  const SkyEstimate first = estimate(paint(zenith_camera(), two_lamps), 1 + 0);
  EXPECT_TRUE(first.sources.empty());
  // Sun separation off: nothing separated, whatever max_sources.
  const SkyEstimate off = estimate(paint(zenith_camera(), two_lamps), 8, SunMode::Off);
  EXPECT_TRUE(off.sources.empty());
  EXPECT_EQ(removed_faces(off), 0);
}

TEST(SeparatedSources, BlackSkyAndBadPixelsGiveNoBogusSources) {
  const SkyEstimate black = estimate(paint(zenith_camera(), [](const Vec3&) { return Eigen::Vector3d::Zero(); }), 8);
  EXPECT_FALSE(black.sun);
  EXPECT_TRUE(black.sources.empty());
  EXPECT_NE(black.sources_reason.find("black"), std::string::npos) << black.sources_reason;
  // NaN, Inf and negative pixels scattered over the lamp sky: the two lamps still, finite.
  RadianceFrame frame = paint(zenith_camera(), two_lamps);
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -5.0f};
  for (int y = 10; y < frame.radiance.rows; y += 37) {
    for (int x = 7; x < frame.radiance.cols; x += 29) frame.radiance.at<cv::Vec3f>(y, x) = cv::Vec3f::all(bad[(x + y) % 3]);
  }
  const SkyEstimate e = estimate(frame, 8);
  ASSERT_EQ(e.sources.size(), 2u) << e.sources_reason;
  for (const Sun& s : e.sources) {
    EXPECT_TRUE(s.energy.allFinite() && s.direction.allFinite());
    EXPECT_GT(s.energy.minCoeff(), 0.0);
  }
  EXPECT_GT(e.luminance.nan_pixels + e.luminance.inf_pixels, 0);
}

TEST(SeparatedSources, MaxSourcesBelowOneIsAnInputError) {
  static const geom::Dome dome(2);
  SkyEstimateOptions options;
  options.max_sources = 0;
  EXPECT_THROW(SkyEstimator(zenith_camera(), dome, options), InputError);
}

}  // namespace
}  // namespace skylit::sky
