// The sky simulator: equirect geometry, fisheye rendering of equirects and analytic skies
// (energy conserved, the sun where the lens puts it), 8-bit clipping.
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <random>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"

namespace {

using namespace skylit::sky;
namespace camera = skylit::camera;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Vec3 from_angles(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * kDeg;
  const double el = elevation_deg * kDeg;
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

// An equidistant fisheye looking at the zenith with identity R_site_from_camera, as
// config/sky_camera.yaml: camera x = east, camera y (image down) = north, camera z = up.
camera::CameraCalibration zenith_fisheye(int size, double focal, std::vector<double> D = {0, 0, 0, 0}) {
  camera::CameraCalibration c;
  c.image_width = size;
  c.image_height = size;
  c.model = camera::LensModel::Fisheye;
  c.fx = c.fy = focal;
  c.cx = c.cy = (size - 1) / 2.0;
  c.D = std::move(D);
  return c;
}

Eigen::Vector3d rgb_at(const cv::Mat& image, int x, int y) {
  const cv::Vec3f p = image.at<cv::Vec3f>(y, x);
  return {p[2], p[1], p[0]};
}

cv::Point peak_of(const cv::Mat& image) {
  cv::Mat channels[3];
  cv::split(image, channels);
  cv::Point where;
  cv::minMaxLoc(channels[1], nullptr, nullptr, nullptr, &where);
  return where;
}

SkyFunction black_sky_with_sun(const Vec3& direction, const Eigen::Vector3d& irradiance) {
  SkyFunction f;
  f.sky = [](const Vec3&) { return Eigen::Vector3d::Zero().eval(); };
  SunDisc disc;
  disc.direction = direction.normalized();
  disc.irradiance = irradiance;
  f.sun = disc;
  return f;
}

}  // namespace

TEST(Equirect, ConventionAndRoundTrip) {
  const int w = 64, h = 32;
  // The centre line looks north, a quarter further east, the top edge is the zenith.
  EXPECT_LE((equirect_direction(w, h, w / 2.0 - 0.5, h / 2.0 - 0.5) - Vec3(0, 1, 0)).norm(), 1e-12);
  EXPECT_LE((equirect_direction(w, h, 3 * w / 4.0 - 0.5, h / 2.0 - 0.5) - Vec3(1, 0, 0)).norm(), 1e-12);
  EXPECT_LE((equirect_direction(w, h, w / 4.0 - 0.5, h / 2.0 - 0.5) - Vec3(-1, 0, 0)).norm(), 1e-12);
  EXPECT_LE((equirect_direction(w, h, 10, -0.5) - Vec3(0, 0, 1)).norm(), 1e-12);
  EXPECT_LE((equirect_direction(w, h, 10, h - 0.5) - Vec3(0, 0, -1)).norm(), 1e-12);
  EXPECT_NEAR(equirect_pixel(w, h, Vec3(0, 1, 0)).x(), w / 2.0 - 0.5, 1e-12);
  EXPECT_NEAR(equirect_pixel(w, h, Vec3(0, -1, 0)).x(), -0.5, 1e-12);  // south: the left edge
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-0.5, w - 0.5), uy(-0.49, h - 0.51);
  for (int k = 0; k < 1000; ++k) {
    const Vec2 p(ux(rng), uy(rng));
    const Vec3 d = equirect_direction(w, h, p.x(), p.y());
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    const Vec2 q = equirect_pixel(w, h, d * 2.5);
    EXPECT_LE((q - p).norm(), 1e-9) << p.transpose() << " → " << q.transpose();
  }
  double total = 0, upper = 0;
  for (int row = 0; row < h; ++row) {
    const double omega = equirect_pixel_solid_angle(w, h, row) * w;
    total += omega;
    if (row < h / 2) upper += omega;
  }
  EXPECT_NEAR(total, 4 * kPi, 1e-12);
  EXPECT_NEAR(upper, 2 * kPi, 1e-12);
}

TEST(RenderFisheye, ConstantEquirectGivesConstantWhereTheLensSees) {
  // k1 < 0 folds the model over at θ ≈ 105°: the image's corners cannot be imaged.
  const camera::Lens lens(zenith_fisheye(96, 30.0, {-0.1, 0, 0, 0}));
  const cv::Mat equirect(16, 32, CV_32FC3, cv::Scalar(0.25, 0.5, 2.0));
  const cv::Mat image = render_fisheye(lens, equirect, RenderOptions{3, 0});
  ASSERT_EQ(image.type(), CV_32FC3);
  ASSERT_EQ(image.size(), cv::Size(96, 96));
  int seen = 0, unseen = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const Eigen::Vector3d rgb = rgb_at(image, x, y);
      if (lens.pixel_to_site(Vec2(x, y))) {
        ++seen;
        EXPECT_NEAR(rgb.x(), 2.0, 1e-5);
        EXPECT_NEAR(rgb.y(), 0.5, 1e-6);
        EXPECT_NEAR(rgb.z(), 0.25, 1e-6);
      } else {
        ++unseen;
        EXPECT_EQ(rgb, Eigen::Vector3d::Zero());
      }
    }
  }
  EXPECT_GT(seen, 1000);
  EXPECT_GT(unseen, 100);
}

TEST(RenderFisheye, ConservesTheEnergyOfARealSky) {
  // The real park capture: half-float, negatives, a sun near 10^4. 512 px across the
  // hemisphere is one fisheye pixel per 0.35°, finer than the equirect's 0.7°.
  const cv::Mat equirect = read_sky_image(std::string(SKYLIT_SOURCE_DIR) + "/data/hdri/park.exr");
  ASSERT_EQ(equirect.type(), CV_32FC3);
  const camera::Lens lens(zenith_fisheye(512, 511.0 / kPi));
  const cv::Mat image = render_fisheye(lens, equirect, RenderOptions{4, 0});
  const Eigen::Vector3d expected = equirect_hemisphere_energy(equirect);
  const Eigen::Vector3d got = fisheye_hemisphere_energy(lens, image);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got[c] / expected[c], 1.0, 0.01) << "channel " << c << ": " << got[c] << " vs " << expected[c];
  }
  // Turning the equirect turns the picture, not its energy.
  const cv::Mat turned = render_fisheye(lens, equirect, RenderOptions{2, 1.0});
  const Eigen::Vector3d got_turned = fisheye_hemisphere_energy(lens, turned);
  EXPECT_NEAR(got_turned.sum() / expected.sum(), 1.0, 0.01);
}

TEST(RenderFisheye, AzimuthOffsetTurnsTheEquirect) {
  // A bright patch due north (at the equirect's centre column), 30° up.
  const int w = 360, h = 180;
  cv::Mat equirect(h, w, CV_32FC3, cv::Scalar::all(0));
  const Vec2 p = equirect_pixel(w, h, from_angles(0, 30));
  equirect(cv::Rect(static_cast<int>(p.x()) - 2, static_cast<int>(p.y()) - 2, 6, 6)).setTo(cv::Scalar::all(100));
  const camera::Lens lens(zenith_fisheye(128, 127.0 / kPi));
  for (const double offset_deg : {0.0, 90.0, -45.0}) {
    const cv::Mat image = render_fisheye(lens, equirect, RenderOptions{2, offset_deg * kDeg});
    const cv::Point peak = peak_of(image);
    const auto expected = lens.site_to_pixel(from_angles(offset_deg, 30));
    ASSERT_TRUE(expected.has_value());
    EXPECT_LE(std::hypot(peak.x - expected->x(), peak.y - expected->y()), 3.0) << "offset " << offset_deg;
  }
}

TEST(RenderFisheye, SunAppearsWhereTheLensPutsItWithItsEnergy) {
  const camera::Lens lens(zenith_fisheye(256, 255.0 / kPi));
  const Eigen::Vector3d irradiance(90, 80, 60);
  for (const auto& [az, el] : {std::pair{120.0, 40.0}, std::pair{300.0, 70.0}, std::pair{10.0, 8.0},
                               std::pair{0.0, 90.0}}) {
    SCOPED_TRACE("sun at azimuth " + std::to_string(az) + ", elevation " + std::to_string(el));
    const Vec3 sun = from_angles(az, el);
    const cv::Mat image = render_fisheye(lens, black_sky_with_sun(sun, irradiance), RenderOptions{1, 0});
    const auto expected = lens.site_to_pixel(sun);
    ASSERT_TRUE(expected.has_value());
    const cv::Point peak = peak_of(image);
    EXPECT_LE(std::hypot(peak.x - expected->x(), peak.y - expected->y()), 1.0);
    const Eigen::Vector3d energy = fisheye_hemisphere_energy(lens, image);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(energy[c] / irradiance[c], 1.0, 1e-3);
  }
  // Identity R: image x increases towards east, image y towards north.
  const auto east = lens.site_to_pixel(from_angles(90, 45));
  const auto north = lens.site_to_pixel(from_angles(0, 45));
  ASSERT_TRUE(east && north);
  EXPECT_GT(east->x(), 140);
  EXPECT_NEAR(east->y(), 127.5, 1e-6);
  EXPECT_GT(north->y(), 140);
}

TEST(RenderFisheye, ClearSkyEnergyMatchesTheModel) {
  const ClearSky sky(from_angles(135, 35), 3.0);
  const camera::Lens lens(zenith_fisheye(192, 191.0 / kPi));
  const cv::Mat image = render_fisheye(lens, sky_function(sky), RenderOptions{2, 0});
  // ∫ L dω of the sky by quadrature (fine grid), plus the disc.
  Eigen::Vector3d expected = Eigen::Vector3d::Zero();
  const int rings = 300, sectors = 600;
  for (int i = 0; i < rings; ++i) {
    const double mu = (i + 0.5) / rings;
    const double s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < sectors; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / sectors;
      expected += sky.sky_radiance(Vec3(s * std::cos(phi), s * std::sin(phi), mu));
    }
  }
  expected *= 2 * kPi / (rings * sectors);
  expected += sky.sun().irradiance;
  const Eigen::Vector3d got = fisheye_hemisphere_energy(lens, image);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c] / expected[c], 1.0, 0.01) << "channel " << c;
  // The sun is the brightest pixel and sits where the lens puts it.
  const cv::Point peak = peak_of(image);
  const auto at = lens.site_to_pixel(sky.sun_direction());
  ASSERT_TRUE(at.has_value());
  EXPECT_LE(std::hypot(peak.x - at->x(), peak.y - at->y()), 1.0);
  // Overcast: no sun, zenith three times the horizon.
  const cv::Mat overcast = render_fisheye(lens, sky_function(OvercastSky(3.0)), RenderOptions{1, 0});
  EXPECT_NEAR(overcast.at<cv::Vec3f>(95, 95)[1], 3.0, 0.01);
}

TEST(RenderEquirect, SkyAndSunEnergy) {
  const ClearSky sky(from_angles(250, 50), 3.0);
  const int w = 256, h = 128;
  const cv::Mat equirect = render_equirect(sky_function(sky), w, h, RenderOptions{2, 0});
  ASSERT_EQ(equirect.size(), cv::Size(w, h));
  // Sun alone: exact to the cell count, peak at its pixel.
  const cv::Mat sun_only = render_equirect(black_sky_with_sun(sky.sun_direction(), sky.sun().irradiance), w, h);
  const Eigen::Vector3d sun_energy = equirect_hemisphere_energy(sun_only);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sun_energy[c] / sky.sun().irradiance[c], 1.0, 1e-6);
  const Vec2 at = equirect_pixel(w, h, sky.sun_direction());
  const cv::Point peak = peak_of(sun_only);
  EXPECT_LE(std::hypot(peak.x - at.x(), peak.y - at.y()), 1.0);
  // The lower half is black; the rendered sky carries the sun's energy on top of the sky's.
  EXPECT_EQ(cv::countNonZero(equirect.rowRange(h / 2, h).reshape(1)), 0);
  EXPECT_GT(equirect_hemisphere_energy(equirect).sum(), sun_energy.sum());
  // A fisheye of the rendered equirect keeps the energy (sun included).
  const camera::Lens lens(zenith_fisheye(256, 255.0 / kPi));
  const cv::Mat image = render_fisheye(lens, equirect, RenderOptions{4, 0});
  const Eigen::Vector3d a = equirect_hemisphere_energy(equirect);
  const Eigen::Vector3d b = fisheye_hemisphere_energy(lens, image);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(b[c] / a[c], 1.0, 0.01) << "channel " << c;
}

TEST(To8bit, ClipsAndEncodesSrgb) {
  cv::Mat radiance(1, 6, CV_32FC3);
  radiance.at<cv::Vec3f>(0, 0) = cv::Vec3f(0, 0, 0);
  radiance.at<cv::Vec3f>(0, 1) = cv::Vec3f(0.5f, 0.25f, 0.125f);  // × 2: 1, 0.5, 0.25
  radiance.at<cv::Vec3f>(0, 2) = cv::Vec3f(100, 100, 100);        // clipped
  radiance.at<cv::Vec3f>(0, 3) = cv::Vec3f(std::nanf(""), -1, std::numeric_limits<float>::infinity());
  radiance.at<cv::Vec3f>(0, 4) = cv::Vec3f(0.001f, 0.001f, 0.001f);  // linear segment: 12.92 × 0.002
  radiance.at<cv::Vec3f>(0, 5) = cv::Vec3f(0.1f, 0.2f, 0.3f);
  const cv::Mat out = to_8bit(radiance, 2.0);
  ASSERT_EQ(out.type(), CV_8UC3);
  EXPECT_EQ(out.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(out.at<cv::Vec3b>(0, 1), cv::Vec3b(255, 188, 137));  // sRGB(0.5) = 0.7354, sRGB(0.25) = 0.5371
  EXPECT_EQ(out.at<cv::Vec3b>(0, 2), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(out.at<cv::Vec3b>(0, 3), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(out.at<cv::Vec3b>(0, 4), cv::Vec3b(7, 7, 7));
  // Channel order is kept (B, G, R in, B, G, R out): brighter input, brighter code.
  const cv::Vec3b p = out.at<cv::Vec3b>(0, 5);
  EXPECT_LT(p[0], p[1]);
  EXPECT_LT(p[1], p[2]);
  EXPECT_THROW(to_8bit(radiance, 0.0), std::invalid_argument);
  EXPECT_THROW(to_8bit(cv::Mat(2, 2, CV_8UC3), 1.0), std::invalid_argument);
}

TEST(Render, RejectsBadArguments) {
  const camera::Lens lens(zenith_fisheye(32, 10.0));
  const cv::Mat equirect(8, 16, CV_32FC3, cv::Scalar::all(1));
  EXPECT_THROW(render_fisheye(lens, equirect, RenderOptions{0, 0}), std::invalid_argument);
  EXPECT_THROW(render_fisheye(lens, equirect, RenderOptions{17, 0}), std::invalid_argument);
  EXPECT_THROW(render_fisheye(lens, cv::Mat(8, 16, CV_8UC3), RenderOptions{}), std::invalid_argument);
  EXPECT_THROW(render_fisheye(lens, cv::Mat(), RenderOptions{}), std::invalid_argument);
  EXPECT_THROW(render_fisheye(lens, SkyFunction{}, RenderOptions{}), std::invalid_argument);
  EXPECT_THROW(render_equirect(sky_function(OvercastSky()), 1, 1), std::invalid_argument);
}
