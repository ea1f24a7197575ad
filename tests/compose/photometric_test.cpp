// The photometric estimator on synthetic frames: it recovers the scale (and white balance) of a
// noisy reference region with shadowed, clipped, black and NaN pixels in it, says when the region
// is unusable, and refuses mismatched inputs.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"
#include "skylit/render/photometric.hpp"

namespace skylit::render {
namespace {

using Eigen::Vector3d;

TEST(PhotometricMatch, MedianRecoversTheScaleDespiteOutliers) {
  const Vector3d k(0.8, 0.55, 0.4);          // exposure × white balance
  const Vector3d albedo(0.35, 0.3, 0.25);    // the reference region's
  const Vector3d irradiance(1.6, 1.8, 2.1);  // its plane's D for this sky
  const Vector3d value = k.cwiseProduct(albedo.cwiseProduct(irradiance) / std::numbers::pi);

  cv::Mat frame(120, 200, CV_32FC3, cv::Scalar::all(0.9));  // outside the region: bright, ignored
  cv::Mat region(frame.size(), CV_8U, cv::Scalar(0));
  region(cv::Rect(20, 10, 150, 100)).setTo(255);
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 0.04);
  std::uniform_real_distribution<double> pick(0.0, 1.0);
  int outliers = 0;
  for (int y = 10; y < 110; ++y) {
    for (int x = 20; x < 170; ++x) {
      Vector3d p = value * (1.0 + noise(random));
      const double u = pick(random);
      if (u < 0.10) {
        p *= 0.25;  // a person's shadow
      } else if (u < 0.13) {
        p = Vector3d::Constant(1.0);  // a reflection, clipped
        ++outliers;
      } else if (u < 0.14) {
        p = Vector3d::Zero();  // dead pixels
        ++outliers;
      } else if (u < 0.15) {
        p = Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
        ++outliers;
      }
      frame.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(p.z()), static_cast<float>(p.y()), static_cast<float>(p.x()));
    }
  }
  const PhotometricEstimate estimate = estimate_photometric_match(frame, region, irradiance, albedo);
  ASSERT_TRUE(estimate.ok) << estimate.problem;
  EXPECT_EQ(estimate.pixels_rejected, outliers);
  EXPECT_EQ(estimate.pixels_used + estimate.pixels_rejected, 150 * 100);
  for (int c = 0; c < 3; ++c) {
    // 10% shadowed pixels move the median by ~0.1 σ quantiles: about 1% with σ = 4%.
    EXPECT_NEAR(estimate.match.scale[c] / k[c], 1.0, 0.015) << "channel " << c;
    EXPECT_NEAR(estimate.spread[c], 0.03, 0.015) << "channel " << c;  // ≈ 0.67 σ of the noise
  }
}

TEST(PhotometricMatch, TooFewUsablePixelsIsNoEstimate) {
  cv::Mat frame(50, 50, CV_32FC3, cv::Scalar::all(1.0));  // all clipped
  cv::Mat region(frame.size(), CV_8U, cv::Scalar(255));
  PhotometricEstimate estimate = estimate_photometric_match(frame, region, Vector3d::Ones(), Vector3d::Constant(0.3));
  EXPECT_FALSE(estimate.ok);
  EXPECT_EQ(estimate.pixels_used, 0);
  EXPECT_NE(estimate.problem.find("usable pixels"), std::string::npos) << estimate.problem;
  EXPECT_EQ(estimate.match.scale, Vector3d::Ones());  // left at its default

  frame.setTo(cv::Scalar::all(0.2));
  region.setTo(0);
  region(cv::Rect(0, 0, 5, 5)).setTo(255);  // 25 pixels
  estimate = estimate_photometric_match(frame, region, Vector3d::Ones(), Vector3d::Constant(0.3));
  EXPECT_FALSE(estimate.ok);
  PhotometricOptions options;
  options.min_pixels = 20;
  estimate = estimate_photometric_match(frame, region, Vector3d::Ones(), Vector3d::Constant(0.3), options);
  EXPECT_TRUE(estimate.ok);
  EXPECT_NEAR(estimate.match.scale.x(), 0.2 / (0.3 / std::numbers::pi), 1e-6);
}

TEST(PhotometricMatch, MismatchedInputsAreInputErrors) {
  const cv::Mat frame(50, 50, CV_32FC3, cv::Scalar::all(0.2));
  const cv::Mat region(50, 50, CV_8U, cv::Scalar(255));
  EXPECT_THROW(estimate_photometric_match(frame, cv::Mat(40, 50, CV_8U), Vector3d::Ones(), Vector3d::Ones()), InputError);
  EXPECT_THROW(estimate_photometric_match(cv::Mat(50, 50, CV_8UC3), region, Vector3d::Ones(), Vector3d::Ones()), InputError);
  EXPECT_THROW(estimate_photometric_match(frame, region, Vector3d(1, 0, 1), Vector3d::Ones()), InputError);
  EXPECT_THROW(estimate_photometric_match(frame, region, Vector3d::Ones(), Vector3d(0.3, std::nan(""), 0.3)), InputError);
}

}  // namespace
}  // namespace skylit::render
