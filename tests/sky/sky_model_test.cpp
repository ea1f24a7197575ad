// The analytic skies: Preetham clear sky with its solar disc, CIE overcast. Integrals are
// checked by midpoint quadrature with the tolerances stated beside each.
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "skylit/base/error.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/camera/lens.hpp"

namespace sky_model_test {  // named, not anonymous: the test program is one unity build

using skylit::sky::ClearSky;
using skylit::sky::OvercastSky;
using skylit::sky::rgb_luminance;
using skylit::camera::Vec3;

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

Vec3 from_angles(double azimuth_deg, double elevation_deg) {
  const double az = azimuth_deg * kDeg;
  const double el = elevation_deg * kDeg;
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

// ∫ f(ω) (cos θ if cosine) dω over the upper hemisphere, midpoint rule in (cos θ, φ).
double hemisphere_integral(const std::function<double(const Vec3&)>& f, bool cosine, int rings = 400) {
  const int sectors = 2 * rings;
  double sum = 0;
  for (int i = 0; i < rings; ++i) {
    const double mu = (i + 0.5) / rings;
    const double s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < sectors; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / sectors;
      const Vec3 d(s * std::cos(phi), s * std::sin(phi), mu);
      sum += f(d) * (cosine ? mu : 1.0);
    }
  }
  return sum * (1.0 / rings) * (2 * kPi / sectors);
}


TEST(ClearSky, SymmetricAboutTheSunsVerticalPlane) {
  const ClearSky sky(from_angles(130, 35), 3.0);
  // Normal of the vertical plane through the sun.
  const Vec3 horizontal = Vec3(sky.sun_direction().x(), sky.sun_direction().y(), 0).normalized();
  const Vec3 normal = horizontal.cross(Vec3::UnitZ());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 500; ++k) {
    Vec3 d(u(rng), u(rng), std::abs(u(rng)) + 0.01);
    d.normalize();
    const Vec3 mirrored = d - 2 * d.dot(normal) * normal;
    const Eigen::Vector3d a = sky.radiance(d);
    const Eigen::Vector3d b = sky.radiance(mirrored);
    EXPECT_LE((a - b).norm(), 1e-9 * (1 + a.norm())) << d.transpose();
  }
}

TEST(ClearSky, BrightestNearTheSun) {
  for (const double elevation : {15.0, 35.0, 60.0, 80.0}) {
    SCOPED_TRACE("sun elevation " + std::to_string(elevation));
    const ClearSky sky(from_angles(200, elevation), 3.0);
    Vec3 brightest = Vec3::UnitZ();
    double best = -1;
    for (int az = 0; az < 360; az += 1) {
      for (double el = 0.5; el < 90; el += 1.0) {
        const Vec3 d = from_angles(az, el);
        const double l = rgb_luminance(sky.sky_radiance(d));
        if (l > best) {
          best = l;
          brightest = d;
        }
      }
    }
    // The circumsolar peak: within the 1° grid of the sun.
    EXPECT_LT(std::acos(std::min(1.0, brightest.dot(sky.sun_direction()))) / kDeg, 1.5);
    // Away from the sun the sky is darker by a large factor (a high sun's sky is flatter:
    // its horizon brightens).
    if (elevation <= 60) {
      EXPECT_GT(best, 3 * rgb_luminance(sky.sky_radiance(from_angles(290, 30))));
    }
  }
}

TEST(ClearSky, SunDiscEnergyIsTheDocumentedDni) {
  for (const double elevation : {5.0, 30.0, 60.0}) {
    const ClearSky sky(from_angles(100, elevation), 3.0);
    const auto& sun = sky.sun();
    ASSERT_GT(sun.irradiance.minCoeff(), 0.0);
    // ∫ (radiance − sky) dω over a cap of twice the disc's radius, in rings of equal solid angle.
    const Vec3 d = sun.direction;
    const Vec3 u = d.cross(Vec3::UnitZ()).normalized();
    const Vec3 v = d.cross(u);
    const double cap = 2 * sun.angular_radius;
    const int rings = 1000, sectors = 64;
    const double ring_omega = 2 * kPi * (1 - std::cos(cap)) / (rings * sectors);
    Eigen::Vector3d energy = Eigen::Vector3d::Zero();
    for (int i = 0; i < rings; ++i) {
      const double cos_a = 1 - (i + 0.5) / rings * (1 - std::cos(cap));
      const double sin_a = std::sqrt(1 - cos_a * cos_a);
      for (int j = 0; j < sectors; ++j) {
        const double phi = 2 * kPi * (j + 0.5) / sectors;
        const Vec3 w = cos_a * d + sin_a * (std::cos(phi) * u + std::sin(phi) * v);
        energy += (sky.radiance(w) - sky.sky_radiance(w)) * ring_omega;
      }
    }
    // Ring boundaries cut the disc's edge: 1/1000 of the cap's cos range, under 0.5%.
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(energy[c] / sun.irradiance[c], 1.0, 5e-3);
    EXPECT_NEAR(sun.solid_angle(), kPi * sun.angular_radius * sun.angular_radius, 1e-9);
  }
}

// DNI from ESRA's beam model, the sky scaled to ESRA's diffuse: at mid elevations and
// turbidity 3 the sun gives 5–10× the sky's horizontal irradiance.
TEST(ClearSky, RealisticSunToSkyRatio) {
  for (const double elevation : {30.0, 45.0, 60.0}) {
    SCOPED_TRACE("sun elevation " + std::to_string(elevation));
    const ClearSky sky(from_angles(160, elevation), 3.0);
    const double dhi = hemisphere_integral([&](const Vec3& d) { return rgb_luminance(sky.sky_radiance(d)); },
                                           true, 200);
    // The quadrature and the model's own (coarser) normalisation agree within 1%.
    EXPECT_NEAR(dhi / sky.diffuse_horizontal(), 1.0, 0.01);
    const double dni = rgb_luminance(sky.sun().irradiance);
    EXPECT_GT(dni / dhi, 5.0);
    EXPECT_LT(dni / dhi, 10.0);
    // Plausible magnitudes (klx): direct normal 60–110, diffuse 5–20.
    EXPECT_GT(dni, 60.0);
    EXPECT_LT(dni, 110.0);
    EXPECT_GT(dhi, 5.0);
    EXPECT_LT(dhi, 20.0);
  }
  // Haze: more sky, less sun.
  const ClearSky clear(from_angles(160, 45), 2.0), hazy(from_angles(160, 45), 6.0);
  EXPECT_GT(hazy.diffuse_horizontal(), clear.diffuse_horizontal());
  EXPECT_LT(rgb_luminance(hazy.sun().irradiance), rgb_luminance(clear.sun().irradiance));
}

TEST(ClearSky, ColoursBlueSkyAndReddeningSun) {
  const ClearSky high(from_angles(180, 60), 3.0), low(from_angles(180, 4), 3.0);
  const Eigen::Vector3d zenith = high.sky_radiance(Vec3::UnitZ());
  EXPECT_GT(zenith.z(), zenith.x());  // blue above red
  const auto ratio = [](const Eigen::Vector3d& rgb) { return rgb.x() / rgb.z(); };
  EXPECT_GT(ratio(low.sun().irradiance), 1.5 * ratio(high.sun().irradiance));
  EXPECT_GT(high.sun().irradiance.x(), high.sun().irradiance.z());  // the sun is warm white
}

TEST(ClearSky, BelowTheHorizonAndAtNight) {
  const ClearSky day(from_angles(90, 40), 3.0);
  EXPECT_EQ(day.radiance(Vec3(0, 1, -0.1)), Eigen::Vector3d::Zero());
  EXPECT_EQ(day.radiance(Vec3(0, 0, -1)), Eigen::Vector3d::Zero());
  EXPECT_EQ(day.radiance(Vec3::Zero()), Eigen::Vector3d::Zero());
  // Direction length does not matter.
  EXPECT_LE((day.radiance(Vec3(0, 3, 3)) - day.radiance(Vec3(0, 1, 1))).norm(), 1e-12);

  const ClearSky horizon(from_angles(90, 0.0), 3.0), twilight(from_angles(90, -3.0), 3.0),
      night(from_angles(90, -7.0), 3.0);
  EXPECT_EQ(twilight.sun().irradiance, Eigen::Vector3d::Zero());
  const Vec3 west = from_angles(270, 20);
  const double h = rgb_luminance(horizon.sky_radiance(west));
  EXPECT_GT(h, 0.0);
  EXPECT_NEAR(rgb_luminance(twilight.sky_radiance(west)) / h, 0.5, 1e-6);  // halfway to −6°
  EXPECT_EQ(night.radiance(Vec3::UnitZ()), Eigen::Vector3d::Zero());
  EXPECT_EQ(night.diffuse_horizontal(), 0.0);
  // A sun straight down is no crash.
  const ClearSky nadir(Vec3(0, 0, -1), 3.0);
  EXPECT_EQ(nadir.radiance(Vec3::UnitZ()), Eigen::Vector3d::Zero());
}

TEST(ClearSky, RejectsBadParameters) {
  for (const double t : {1.0, 10.5, std::nan(""), -3.0}) {
    try {
      ClearSky sky(Vec3::UnitZ(), t);
      FAIL() << "turbidity " << t << " accepted";
    } catch (const skylit::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("turbidity"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(ClearSky(Vec3::UnitZ(), 3.0, 0.0), skylit::InputError);
  EXPECT_THROW(ClearSky(Vec3::UnitZ(), 3.0, 0.5), skylit::InputError);
  EXPECT_THROW(ClearSky(Vec3::Zero(), 3.0), std::invalid_argument);
  EXPECT_THROW(ClearSky(Vec3(std::nan(""), 0, 1), 3.0), std::invalid_argument);
}

TEST(OvercastSky, CieDistribution) {
  const OvercastSky sky(4.0);
  const Eigen::Vector3d zenith = sky.radiance(Vec3::UnitZ());
  EXPECT_NEAR(zenith.x(), 4.0, 1e-12);
  EXPECT_EQ(zenith.x(), zenith.z());  // grey
  const Eigen::Vector3d horizon = sky.radiance(Vec3(1, 0, 1e-12));
  EXPECT_NEAR(zenith.x() / horizon.x(), 3.0, 1e-9);
  EXPECT_EQ(sky.radiance(Vec3(1, 0, -0.01)), Eigen::Vector3d::Zero());
  // Diffuse horizontal irradiance 7π/9 L_z; midpoint rule in cos θ is exact for this polynomial.
  const double dhi = hemisphere_integral([&](const Vec3& d) { return sky.radiance(d).x(); }, true, 100);
  EXPECT_NEAR(dhi, 7 * kPi / 9 * 4.0, 1e-3);
  for (const double bad : {0.0, -1.0, std::nan("")}) EXPECT_THROW(OvercastSky{bad}, skylit::InputError);
}

TEST(SkyModel, XyYToSrgb) {
  const Eigen::Vector3d white = skylit::sky::xyY_to_linear_srgb(0.3127, 0.3290, 1.0);  // D65
  EXPECT_NEAR(white.x(), 1.0, 2e-3);
  EXPECT_NEAR(white.y(), 1.0, 2e-3);
  EXPECT_NEAR(white.z(), 1.0, 2e-3);
  EXPECT_NEAR(rgb_luminance(skylit::sky::xyY_to_linear_srgb(0.25, 0.27, 3.0)), 3.0, 3e-3);
  EXPECT_EQ(skylit::sky::xyY_to_linear_srgb(0.3, 0.0, 1.0), Eigen::Vector3d::Zero());
}
}  // namespace sky_model_test
