// The sun's energy from the ground in and out of a real shadow: a textured ground under a
// coloured sky and sun, as a float and as an 8-bit sRGB camera records it, gives E_sun back from
// the two regions' contrast whatever the exposure; no shadow, a sun along the plane or too few
// pixels give no estimate, and bad inputs are refused by name.
#include <cmath>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"
#include "skylit/render/photometric.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"

namespace skylit::render {
namespace shadow_contrast_test {  // named: the test program is one unity build

using Eigen::Vector3d;

// The scene: ground of albedo ρ (a ±15% texture) seen by a camera of scale k; the left half of
// the frame is the lit region, the right half the shadowed one (V of the sky, no sun).
struct Ground {
  Vector3d sky = Vector3d(0.55, 0.75, 1.1);    // D_sky on the plane
  Vector3d sun = Vector3d(3.2, 3.0, 2.6);      // E_sun, normal
  double sun_cos = std::sin(40.0 * std::numbers::pi / 180.0);
  double visibility = 1.0;
  Vector3d albedo = Vector3d(0.25, 0.22, 0.18);
  double exposure = 0.6;                      // k: linear value per unit radiance

  cv::Mat frame(unsigned seed = 3) const {
    cv::Mat image(100, 160, CV_32FC3);
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> texture(0.85, 1.15);
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const bool lit = x < image.cols / 2;
        const Vector3d irradiance = lit ? Vector3d(sky + sun * sun_cos) : Vector3d(visibility * sky);
        const Vector3d p = exposure * texture(random) * albedo.cwiseProduct(irradiance) / std::numbers::pi;
        image.at<cv::Vec3f>(y, x) = cv::Vec3f(static_cast<float>(p.z()), static_cast<float>(p.y()), static_cast<float>(p.x()));
      }
    }
    return image;
  }
  cv::Mat lit_region() const { return half(true); }
  cv::Mat shadowed_region() const { return half(false); }

 private:
  static cv::Mat half(bool left) {
    cv::Mat mask(100, 160, CV_8U, cv::Scalar(0));
    mask(cv::Rect(left ? 0 : 80, 0, 80, 100)).setTo(255);
    return mask;
  }
};

TEST(ShadowContrast, TheGroundInAndOutOfAShadowGivesTheSunsEnergy) {
  for (const double visibility : {1.0, 0.7}) {
    Ground ground;
    ground.visibility = visibility;
    ShadowContrastOptions options;
    options.sky_visibility = visibility;
    const ShadowContrast c = estimate_sun_from_shadow_contrast(ground.frame(), ground.lit_region(), ground.shadowed_region(),
                                                               ground.sky, ground.sun_cos, options);
    ASSERT_TRUE(c.ok) << c.problem;
    EXPECT_EQ(c.lit_pixels, 8000);
    EXPECT_EQ(c.shadowed_pixels, 8000);
    for (int ch = 0; ch < 3; ++ch) {
      // The two regions' textures are independent draws: their medians differ by about 1%.
      EXPECT_NEAR(c.sun_energy[ch] / ground.sun[ch], 1.0, 0.03) << "channel " << ch << ", V " << visibility;
    }
    // A ±15% texture: each region's spread is about 7.5%, the confidence about 0.85.
    EXPECT_GT(c.confidence, 0.8);
    EXPECT_LT(c.confidence, 0.9);
  }
}

TEST(ShadowContrast, AnEightBitCameraExposedForTheGroundMeasuresItAsWell) {
  // The sky camera clips this sun; the HMD camera, exposed for the ground, does not clip the
  // ground. Its 8-bit sRGB codes, read back, still give E_sun within a few per cent.
  const Ground ground;
  const cv::Mat linear = ground.frame();
  const sky::RadianceFrame read = sky::linearise(sky::to_8bit(linear, 1.0), sky::ResponseCurve::srgb(8), {});
  const ShadowContrast c = estimate_sun_from_shadow_contrast(read.radiance, ground.lit_region(), ground.shadowed_region(),
                                                             ground.sky, ground.sun_cos);
  ASSERT_TRUE(c.ok) << c.problem;
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(c.sun_energy[ch] / ground.sun[ch], 1.0, 0.04) << "channel " << ch;
  // Exposure cancels: a camera twice as bright gives the same sun.
  Ground brighter = ground;
  brighter.exposure *= 2.0;
  const ShadowContrast twice = estimate_sun_from_shadow_contrast(brighter.frame(), ground.lit_region(),
                                                                 ground.shadowed_region(), ground.sky, ground.sun_cos);
  ASSERT_TRUE(twice.ok);
  const ShadowContrast once = estimate_sun_from_shadow_contrast(ground.frame(), ground.lit_region(), ground.shadowed_region(),
                                                                ground.sky, ground.sun_cos);
  EXPECT_LT((twice.sun_energy - once.sun_energy).norm(), 1e-6 * once.sun_energy.norm());
}

TEST(ShadowContrast, NoShadowALowSunOrTooFewPixelsIsNoEstimate) {
  Ground overcast;
  overcast.sun.setZero();  // a cloud over the sun: the shadow is gone
  ShadowContrast c = estimate_sun_from_shadow_contrast(overcast.frame(), overcast.lit_region(), overcast.shadowed_region(),
                                                       overcast.sky, overcast.sun_cos);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.problem.find("no contrast"), std::string::npos) << c.problem;
  EXPECT_EQ(c.sun_energy, Vector3d::Zero());

  Ground grazing;
  grazing.sun_cos = std::sin(3.0 * std::numbers::pi / 180.0);
  c = estimate_sun_from_shadow_contrast(grazing.frame(), grazing.lit_region(), grazing.shadowed_region(), grazing.sky,
                                        grazing.sun_cos);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.problem.find("too low"), std::string::npos) << c.problem;

  const Ground ground;
  cv::Mat small(100, 160, CV_8U, cv::Scalar(0));
  small(cv::Rect(100, 10, 5, 5)).setTo(255);  // 25 pixels
  c = estimate_sun_from_shadow_contrast(ground.frame(), ground.lit_region(), small, ground.sky, ground.sun_cos);
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.problem.find("usable pixels"), std::string::npos) << c.problem;
}

TEST(ShadowContrast, BadInputsAreRefusedByName) {
  const Ground ground;
  const cv::Mat frame = ground.frame();
  auto problem = [&](const Vector3d& sky, double visibility, const cv::Mat& shadowed) {
    ShadowContrastOptions options;
    options.sky_visibility = visibility;
    try {
      estimate_sun_from_shadow_contrast(frame, ground.lit_region(), shadowed, sky, ground.sun_cos, options);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(problem(ground.sky, 1.2, ground.shadowed_region()).find("shadowed_sky_visibility"), std::string::npos);
  EXPECT_NE(problem(ground.sky, 0.0, ground.shadowed_region()).find("shadowed_sky_visibility"), std::string::npos);
  EXPECT_NE(problem(Vector3d(0.5, 0.0, 0.5), 1.0, ground.shadowed_region()).find("irradiance"), std::string::npos);
  EXPECT_NE(problem(ground.sky, 1.0, cv::Mat(10, 10, CV_8U, cv::Scalar(255))).find("shadowed_region"), std::string::npos);
}

}  // namespace shadow_contrast_test
}  // namespace skylit::render
