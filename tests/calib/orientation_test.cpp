// The sky camera's orientation from sun directions (Wahba's problem with outliers), and from a
// level and a compass.
#include <chrono>
#include <cmath>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/calib/orientation.hpp"
#include "skylit/sky/solar.hpp"

namespace orientation_test {  // named, not anonymous: the test program is one unity build

using skylit::calib::SunObservation;
using skylit::calib::Vec3;

constexpr double kDeg = std::numbers::pi / 180.0;

// A sky camera tilted 4° off the zenith, its image x axis turned to bearing 37°.
Eigen::Matrix3d tilted_camera() {
  return Eigen::AngleAxisd(4 * kDeg, Vec3(1, 2, 0).normalized()).toRotationMatrix() * skylit::calib::level_compass_rotation(37);
}

// Kyoto, 2026-06-21, the sun every 30 minutes from 08:00 to 16:00 JST.
std::vector<Vec3> sun_directions() {
  std::vector<Vec3> directions;
  const auto start = skylit::sky::parse_utc("2026-06-21T08:00:00+09:00");
  for (int k = 0; k <= 16; ++k) {
    directions.push_back(skylit::sky::solar_position(start + std::chrono::minutes(30 * k), 35.01, 135.77).direction());
  }
  return directions;
}

// A unit vector `sigma_deg` (per axis, Gaussian) off `d`.
Vec3 perturb(const Vec3& d, double sigma_deg, std::mt19937& random) {
  std::normal_distribution<double> gauss(0.0, sigma_deg * kDeg);
  const Vec3 t1 = d.unitOrthogonal();
  const Vec3 t2 = d.cross(t1);
  return (d + gauss(random) * t1 + gauss(random) * t2).normalized();
}

TEST(SkyOrientation, WahbaIsExactOnExactData) {
  const Eigen::Matrix3d R = tilted_camera();
  std::vector<Vec3> site, camera;
  for (const Vec3& s : sun_directions()) {
    site.push_back(s);
    camera.push_back(R.transpose() * s);
  }
  const Eigen::Matrix3d fitted = skylit::calib::solve_wahba(site, camera);
  EXPECT_LT(skylit::calib::rotation_difference_deg(fitted, R), 1e-9);
  EXPECT_NEAR(fitted.determinant(), 1.0, 1e-12);
  // Two directions suffice.
  const std::vector<Vec3> two_site{site[0], site[10]}, two_camera{camera[0], camera[10]};
  EXPECT_LT(skylit::calib::rotation_difference_deg(skylit::calib::solve_wahba(two_site, two_camera), R), 1e-9);
}

TEST(SkyOrientation, RecoversAKnownRotationFromNoisyDetectionsWithOutliers) {
  const Eigen::Matrix3d R = tilted_camera();
  std::mt19937 random(3);
  std::vector<SunObservation> observations;
  const std::vector<Vec3> suns = sun_directions();
  for (std::size_t k = 0; k < suns.size(); ++k) {
    observations.push_back({"frame" + std::to_string(k), perturb(R.transpose() * suns[k], 0.2, random), suns[k]});
  }
  // Two false suns: a reflection 25° off, a cloud edge 8° off.
  observations[3].camera_direction = perturb(observations[3].camera_direction, 25, random);
  observations[11].camera_direction = (observations[11].camera_direction + Vec3(0.14, 0, 0)).normalized();
  const skylit::calib::OrientationFit fit = skylit::calib::fit_orientation(observations);
  const double error = skylit::calib::rotation_difference_deg(fit.R_site_from_camera, R);
  EXPECT_LT(error, 0.5);
  EXPECT_EQ(fit.inliers, static_cast<int>(suns.size()) - 2);
  EXPECT_FALSE(fit.inlier[3]);
  EXPECT_FALSE(fit.inlier[11]);
  EXPECT_GT(fit.residual_deg[3], 5.0);
  EXPECT_LT(fit.rms_deg, 0.5);
  EXPECT_GT(fit.spread_deg, 60.0);
  ASSERT_EQ(fit.advice.size(), 1u) << "names the outliers";
  EXPECT_NE(fit.advice[0].find("frame3"), std::string::npos);
  EXPECT_NE(fit.advice[0].find("frame11"), std::string::npos);
  std::printf("orientation: %.3f° from the true rotation, residual RMS %.3f°, %d inliers\n", error, fit.rms_deg, fit.inliers);
}

TEST(SkyOrientation, TooFewOrParallelSunsSayWhatToDo) {
  const Eigen::Matrix3d R = tilted_camera();
  const std::vector<Vec3> suns = sun_directions();
  const std::vector<SunObservation> one{{"a", R.transpose() * suns[0], suns[0]}};
  try {
    skylit::calib::fit_orientation(one);
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("found in 1 frame(s)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--level-compass"), std::string::npos) << e.what();
  }
  // The sun a minute apart: 0.25°.
  const auto t = skylit::sky::parse_utc("2026-06-21T12:00:00+09:00");
  const Vec3 s1 = skylit::sky::solar_position(t, 35, 135).direction();
  const Vec3 s2 = skylit::sky::solar_position(t + std::chrono::minutes(1), 35, 135).direction();
  const std::vector<SunObservation> close{{"a", R.transpose() * s1, s1}, {"b", R.transpose() * s2, s2}};
  try {
    skylit::calib::fit_orientation(close);
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the sun moved only 0."), std::string::npos) << e.what();
  }
  // A lamp or a reflection found at the same place in every frame while the sun moved: no two
  // frames agree on an orientation.
  std::vector<SunObservation> lamp;
  for (std::size_t k = 0; k < suns.size(); k += 4) {
    lamp.push_back({"lamp" + std::to_string(k), Vec3(0.3, 0.1 + 0.001 * static_cast<double>(k), 1).normalized(), suns[k]});
  }
  try {
    skylit::calib::fit_orientation(lamp);
    FAIL();
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no two frames agree"), std::string::npos) << e.what();
  }
}

TEST(SkyOrientation, LevelCompass) {
  // Image x towards the east: x → (1, 0, 0), y (down the image) → north... seen from below.
  const Eigen::Matrix3d east = skylit::calib::level_compass_rotation(90);
  EXPECT_TRUE(east.col(0).isApprox(Vec3(1, 0, 0), 1e-12));
  EXPECT_TRUE(east.col(1).isApprox(Vec3(0, 1, 0), 1e-12));
  EXPECT_TRUE(east.col(2).isApprox(Vec3(0, 0, 1), 1e-12));
  const Eigen::Matrix3d north = skylit::calib::level_compass_rotation(0);
  EXPECT_TRUE(north.col(0).isApprox(Vec3(0, 1, 0), 1e-12));
  EXPECT_TRUE(north.col(1).isApprox(Vec3(-1, 0, 0), 1e-12));
  for (double bearing : {0.0, 37.0, 181.5, 359.0}) {
    const Eigen::Matrix3d R = skylit::calib::level_compass_rotation(bearing);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    EXPECT_TRUE((R.transpose() * R).isIdentity(1e-12));
    const skylit::calib::Pointing p = skylit::calib::describe_pointing(R);
    EXPECT_NEAR(p.tilt_from_zenith_deg, 0.0, 1e-9);
    EXPECT_NEAR(p.image_x_bearing_deg, bearing, 1e-9);
  }
  EXPECT_NEAR(skylit::calib::describe_pointing(tilted_camera()).tilt_from_zenith_deg, 4.0, 1e-9);
  EXPECT_THROW(skylit::calib::level_compass_rotation(std::nan("")), skylit::InputError);
}

}  // namespace
