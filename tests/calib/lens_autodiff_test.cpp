// The lens projection through automatic differentiation (Ceres' dual numbers), as the marker
// survey's bundle adjustment uses it: the same pixels as project(), and derivatives that match
// central differences for the fisheye and pinhole models, far from and near the image's edge.
#include <cmath>
#include <optional>
#include <vector>

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "skylit/camera/lens.hpp"

namespace {

using skylit::camera::CameraCalibration;
using skylit::camera::Lens;
using skylit::camera::LensModel;
using Jet = ceres::Jet<double, 3>;

CameraCalibration fisheye() {
  CameraCalibration c;
  c.image_width = 1024;
  c.image_height = 1024;
  c.model = LensModel::Fisheye;
  c.fx = c.fy = 330;
  c.cx = c.cy = 511.5;
  c.D = {-0.02, 0.004, -0.001, 0.0002};
  return c;
}

CameraCalibration rational_pinhole() {
  CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = LensModel::Pinhole;
  c.fx = 800;
  c.fy = 805;
  c.cx = 641.2;
  c.cy = 358.7;
  c.D = {-0.08, 0.03, 0.0006, -0.0003, -0.004, 0.01, -0.002, 0.001};
  return c;
}

void expect_derivatives_match(const Lens& lens, const Eigen::Vector3d& d) {
  Eigen::Matrix<Jet, 3, 1> dual;
  for (int k = 0; k < 3; ++k) dual[k] = Jet(d[k], k);
  const std::optional<Eigen::Matrix<Jet, 2, 1>> pixel = lens.project_as<Jet>(dual);
  const std::optional<Eigen::Vector2d> plain = lens.project(d);
  ASSERT_TRUE(pixel && plain) << d.transpose();
  // The same code gives the same pixel (dual numbers divide by multiplying with the reciprocal).
  EXPECT_NEAR(pixel->x().a, plain->x(), 1e-9);
  EXPECT_NEAR(pixel->y().a, plain->y(), 1e-9);
  const double h = 1e-6 * d.norm();
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = d, minus = d;
    plus[k] += h;
    minus[k] -= h;
    const Eigen::Vector2d numeric = (*lens.project(plus) - *lens.project(minus)) / (2 * h);
    const double scale = std::max(1.0, numeric.norm());
    EXPECT_NEAR(pixel->x().v[k], numeric.x(), 1e-5 * scale) << "d pixel.x / d direction[" << k << "] at " << d.transpose();
    EXPECT_NEAR(pixel->y().v[k], numeric.y(), 1e-5 * scale) << "d pixel.y / d direction[" << k << "] at " << d.transpose();
  }
}

TEST(LensAutodiff, FisheyeDerivativesMatchCentralDifferences) {
  const Lens lens(fisheye());
  for (const Eigen::Vector3d& d : std::vector<Eigen::Vector3d>{{0.01, -0.02, 1}, {0.4, 0.3, 0.8}, {-1.5, 0.7, 0.2}, {0.9, -0.9, -0.05}}) {
    expect_derivatives_match(lens, d);
  }
}

TEST(LensAutodiff, PinholeDerivativesMatchCentralDifferences) {
  const Lens lens(rational_pinhole());
  for (const Eigen::Vector3d& d : std::vector<Eigen::Vector3d>{{0.01, -0.02, 1}, {0.5, 0.3, 1}, {-0.7, -0.4, 1.1}, {3.0, 2.0, 4.0}}) {
    expect_derivatives_match(lens, d);
  }
}

TEST(LensAutodiff, LengthDoesNotMatterAtTheExtremes) {
  // A direction is a direction at any length: no square overflows or underflows on the way.
  const Lens lens(fisheye());
  const Eigen::Vector3d d(0.3, -0.2, 0.9);
  const Eigen::Vector2d expected = *lens.project(d);
  for (double length : {1e-300, 1e-150, 1.0, 1e150, 1e300}) {
    const std::optional<Eigen::Vector2d> pixel = lens.project(length * d);
    ASSERT_TRUE(pixel) << length;
    EXPECT_NEAR((*pixel - expected).norm(), 0.0, 1e-9) << length;
  }
  EXPECT_FALSE(lens.project(Eigen::Vector3d::Zero()));
  EXPECT_FALSE(lens.project(Eigen::Vector3d(0, 0, -1)));
  EXPECT_FALSE(lens.project(Eigen::Vector3d(std::nan(""), 0, 1)));
}

}  // namespace
