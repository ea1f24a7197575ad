// The sun's colour: a clear sky's sun reddens towards the horizon; a sun whose measured colour
// is impossible for daylight (a lossy capture that kept only its blue, as data/hdri/park.exr's)
// gets that colour at its elevation, its brightest channel kept, and is flagged; a plausible sun
// and the lamps keep what the pixels say.
#include <cmath>
#include <limits>
#include <numbers>

#include <gtest/gtest.h>

#include "../support/sky_paint.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace sun_colour_test {  // named, not anonymous: the test program is one unity build

constexpr double kDegree = std::numbers::pi / 180.0;

TEST(SunColour, AClearSkysSunReddensTowardsTheHorizonAndIsPlausible) {
  Eigen::Vector3d previous = daylight_sun_colour(90 * kDegree);
  EXPECT_NEAR(previous.maxCoeff(), 1.0, 1e-12);
  EXPECT_GT(previous.z(), 0.8) << "overhead: nearly white";
  for (const double elevation : {60.0, 30.0, 15.0, 8.0, 3.0, 0.0}) {
    const Eigen::Vector3d c = daylight_sun_colour(elevation * kDegree);
    EXPECT_NEAR(c.maxCoeff(), 1.0, 1e-12);
    EXPECT_LT(c.z(), previous.z()) << elevation << "°: bluer light is lost first";
    EXPECT_LE(c.y(), previous.y() + 1e-12) << elevation;
    EXPECT_TRUE(plausible_sun_colour(c) || elevation < 3.0) << elevation << "°: " << c.transpose();
    previous = c;
  }
  EXPECT_TRUE(plausible_sun_colour(Eigen::Vector3d(1.0, 0.95, 0.9)));
  EXPECT_TRUE(plausible_sun_colour(Eigen::Vector3d(3.0, 1.5, 0.4)));  // a sunset
  EXPECT_FALSE(plausible_sun_colour(Eigen::Vector3d(0.0, 0.0, 4.3)));  // park.exr's
  EXPECT_FALSE(plausible_sun_colour(Eigen::Vector3d(0.2, 1.0, 0.2)));  // green
  EXPECT_FALSE(plausible_sun_colour(Eigen::Vector3d(0.5, 0.6, 1.0)));  // bluer than any sun
  EXPECT_FALSE(plausible_sun_colour(Eigen::Vector3d::Zero()));
  EXPECT_FALSE(plausible_sun_colour(Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 1, 1)));
}

TEST(SunColour, AnImpossibleColourIsCorrectedAndFlaggedAPlausibleOneKept) {
  Sun sun;
  sun.direction = Eigen::Vector3d(0.0, std::cos(40 * kDegree), std::sin(40 * kDegree));
  sun.energy = Eigen::Vector3d(0.0, 0.0, 4.3);
  EXPECT_TRUE(correct_sun_colour(sun));
  EXPECT_TRUE(sun.colour_corrected);
  EXPECT_EQ(sun.measured_energy, Eigen::Vector3d(0.0, 0.0, 4.3));
  EXPECT_NEAR(sun.energy.maxCoeff(), 4.3, 1e-12) << "the brightest channel the capture kept";
  EXPECT_LT((sun.energy / 4.3 - daylight_sun_colour(40 * kDegree)).norm(), 1e-12);
  EXPECT_TRUE(plausible_sun_colour(sun.energy));

  Sun white;
  white.direction = sun.direction;
  white.energy = Eigen::Vector3d(4.0, 3.9, 3.6);
  EXPECT_FALSE(correct_sun_colour(white));
  EXPECT_FALSE(white.colour_corrected);
  EXPECT_EQ(white.energy, Eigen::Vector3d(4.0, 3.9, 3.6));
  Sun dark;
  dark.energy = Eigen::Vector3d::Zero();
  EXPECT_FALSE(correct_sun_colour(dark)) << "no light: nothing to colour";
}

// Through the sky stage: a dim sky with a compact sun 40° up whose pixels hold blue only.
TEST(SunColour, TheSkyStageCorrectsTheSunNotTheLamps) {
  camera::CameraCalibration c;
  c.image_width = c.image_height = 400;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = 200.0 / (std::numbers::pi / 2.0);
  c.cx = c.cy = 199.5;
  c.D = {0, 0, 0, 0};
  c.R_site_from_camera = Eigen::Matrix3d::Identity();
  const Vec3 towards = skylit::test::from_angles(120.0, 40.0);
  const Vec3 lamp_at = skylit::test::from_angles(300.0, 50.0);
  const RadianceFrame frame{skylit::test::paint_sky(camera::Lens(c),
                                                    [&](const Vec3& d) -> Eigen::Vector3d {
                                                      if (d.z() < 0) return Eigen::Vector3d::Zero();
                                                      if (skylit::test::angle(d, towards) < 1.2 * kDegree) {
                                                        return Eigen::Vector3d(0.0, 0.0, 400.0);
                                                      }
                                                      if (skylit::test::angle(d, lamp_at) < 2.0 * kDegree) {
                                                        return Eigen::Vector3d(0.0, 0.0, 30.0);  // a blue lamp
                                                      }
                                                      return Eigen::Vector3d(0.05, 0.06, 0.08);
                                                    }),
                            cv::Mat()};
  const geom::Dome dome(2);
  SkyEstimateOptions options;
  options.max_sources = 2;
  const SkyEstimate corrected = SkyEstimator(c, dome, options).estimate(frame);
  ASSERT_TRUE(corrected.sun) << corrected.sun_reason;
  EXPECT_TRUE(corrected.sun->colour_corrected);
  EXPECT_TRUE(plausible_sun_colour(corrected.sun->energy)) << corrected.sun->energy.transpose();
  EXPECT_NEAR(corrected.sun->energy.maxCoeff(), corrected.sun->measured_energy.z(), 1e-9);
  ASSERT_EQ(corrected.sources.size(), 2u) << corrected.sources_reason;
  EXPECT_TRUE(corrected.sources[0].colour_corrected) << "sources[0] is the sun";
  EXPECT_FALSE(corrected.sources[1].colour_corrected) << "a lamp's colour is its own";
  EXPECT_GT(corrected.sources[1].energy.z(), 10.0 * corrected.sources[1].energy.x());

  options.correct_sun_colour = false;
  const SkyEstimate measured = SkyEstimator(c, dome, options).estimate(frame);
  ASSERT_TRUE(measured.sun);
  EXPECT_FALSE(measured.sun->colour_corrected);
  EXPECT_EQ(measured.sun->energy, corrected.sun->measured_energy);
}

}  // namespace sun_colour_test
}  // namespace skylit::sky
