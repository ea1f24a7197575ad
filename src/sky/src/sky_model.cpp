// Preetham clear sky with a solar disc, and the CIE overcast sky.
#include "skylit/sky/sky_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/geom/angles.hpp"

namespace skylit::sky {
namespace {

using geom::kPi;
using geom::kDeg;
constexpr double kTwilightDepth = 6.0 * kDeg;      // civil twilight: the sky is black below −6°
constexpr double kMinTurbidity = 2.0;
constexpr double kMaxTurbidity = 10.0;
// Effective wavelengths (µm) of the R, G, B channels for the sun's attenuation.
constexpr std::array<double, 3> kChannelWavelength = {0.61, 0.55, 0.465};

// Kasten and Young (1989) relative optical air mass, finite at the horizon (≈ 38).
double air_mass(double elevation) {
  const double zenith_deg = 90.0 - elevation / kDeg;
  return 1.0 / (std::cos(zenith_deg * kDeg) + 0.50572 * std::pow(96.07995 - zenith_deg, -1.6364));
}

// Kasten's Rayleigh optical thickness of the clean dry atmosphere along air mass m (ESRA).
double rayleigh_thickness(double m) {
  if (m > 20.0) return 1.0 / (10.4 + 0.718 * m);
  return 1.0 / (6.6296 + m * (1.7513 + m * (-0.1202 + m * (0.0065 - m * 0.00013))));
}

// ESRA diffuse horizontal irradiance as a fraction of E0, for Linke turbidity tl.
double esra_diffuse_fraction(double tl, double elevation) {
  const double transmission = -1.5843e-2 + tl * (3.0543e-2 + tl * 3.797e-4);
  double a0 = 2.6463e-1 + tl * (-6.1581e-2 + tl * 3.1408e-3);
  if (a0 * transmission < 2e-3) a0 = 2e-3 / transmission;
  const double a1 = 2.0402 + tl * (1.8945e-2 - tl * 1.1161e-2);
  const double a2 = -1.3025 + tl * (3.9231e-2 + tl * 8.5079e-3);
  const double s = std::sin(std::max(elevation, 0.0));
  return transmission * (a0 + a1 * s + a2 * s * s);
}

}  // namespace

double SunDisc::solid_angle() const { return 2.0 * kPi * (1.0 - std::cos(angular_radius)); }

bool SunDisc::contains(const Vec3& unit_direction) const {
  return unit_direction.dot(direction) >= std::cos(angular_radius);
}

double ClearSky::Perez::operator()(double cos_theta, double gamma, double cos_gamma) const {
  // Directions at the horizon would divide by 0; b < 0 for every turbidity allowed, so the
  // exponential simply vanishes there.
  const double ct = std::max(cos_theta, 1e-4);
  return (1.0 + a * std::exp(b / ct)) * (1.0 + c * std::exp(d * gamma) + e * cos_gamma * cos_gamma);
}

ClearSky::ClearSky(const Vec3& sun_direction, double turbidity, double sun_angular_radius)
    : turbidity_(turbidity) {
  if (!std::isfinite(turbidity) || turbidity < kMinTurbidity || turbidity > kMaxTurbidity) {
    throw InputError(input_message("", -1, -1, "turbidity",
                                   "got " + std::to_string(turbidity) + ", outside [2, 10] where the Preetham "
                                   "sky model holds",
                                   "use 2 (very clear) to 10 (hazy); 3 is a clear day"));
  }
  if (!std::isfinite(sun_angular_radius) || sun_angular_radius <= 0 || sun_angular_radius > 0.1) {
    throw InputError(input_message("", -1, -1, "sun_angular_radius",
                                   "got " + std::to_string(sun_angular_radius) + " rad, outside (0, 0.1]",
                                   "leave the default, 0.00465 rad (the real sun)"));
  }
  const double length = sun_direction.norm();
  if (!std::isfinite(length) || length == 0) throw std::invalid_argument("ClearSky: sun direction is zero or not finite");
  sun_.direction = sun_direction / length;
  sun_.angular_radius = sun_angular_radius;

  const double elevation = std::asin(std::clamp(sun_.direction.z(), -1.0, 1.0));
  shape_sun_ = sun_.direction;
  double twilight = 1.0;
  if (elevation < 0) {
    // Keep the sky's shape of a sun on the horizon (Preetham is undefined below it), fade it.
    const Vec3 horizontal(sun_.direction.x(), sun_.direction.y(), 0.0);
    shape_sun_ = horizontal.norm() > 0 ? Vec3(horizontal.normalized()) : Vec3::UnitX();
    twilight = std::max(0.0, 1.0 + elevation / kTwilightDepth);
  }

  const double t = turbidity;
  perez_Y_ = {0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251, 0.1206 * t - 2.5771,
              -0.0670 * t + 0.3703};
  perez_x_ = {-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125, -0.0641 * t - 0.8989,
              -0.0033 * t + 0.0452};
  perez_y_ = {-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102, -0.0441 * t - 1.6537,
              -0.0109 * t + 0.0529};

  const double theta_s = std::acos(std::clamp(shape_sun_.z(), -1.0, 1.0));
  // Preetham's zenith luminance only sets a provisional level: the sky is rescaled below.
  const double chi = (4.0 / 9.0 - t / 120.0) * (kPi - 2.0 * theta_s);
  zenith_Y_ = (4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192;
  const double th = theta_s, th2 = th * th, th3 = th2 * th;
  zenith_x_ = t * t * (0.00166 * th3 - 0.00375 * th2 + 0.00209 * th) +
              t * (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * th + 0.00394) +
              (0.11693 * th3 - 0.21196 * th2 + 0.06052 * th + 0.25886);
  zenith_y_ = t * t * (0.00275 * th3 - 0.00610 * th2 + 0.00317 * th) +
              t * (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * th + 0.00516) +
              (0.15346 * th3 - 0.26756 * th2 + 0.06670 * th + 0.26688);
  const double cos_s = std::cos(theta_s);
  norm_Y_ = perez_Y_(1.0, theta_s, cos_s);
  norm_x_ = perez_x_(1.0, theta_s, cos_s);
  norm_y_ = perez_y_(1.0, theta_s, cos_s);

  // Level: ∫ Y cos θ dω of the shape, midpoint rule in (cos θ, φ) where dω = d(cos θ) dφ; the
  // Perez function is smooth, so 64 × 128 cells are within 0.1%.
  constexpr int kRings = 64;
  constexpr int kSectors = 128;
  double shape_dhi = 0;
  for (int i = 0; i < kRings; ++i) {
    const double mu = (i + 0.5) / kRings;
    const double sin_theta = std::sqrt(1.0 - mu * mu);
    for (int j = 0; j < kSectors; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / kSectors;
      const Vec3 d(sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu);
      const double cos_gamma = std::clamp(d.dot(shape_sun_), -1.0, 1.0);
      shape_dhi += sky_xyY(mu, std::acos(cos_gamma), cos_gamma).z() * mu;
    }
  }
  shape_dhi *= (1.0 / kRings) * (2.0 * kPi / kSectors);
  diffuse_horizontal_ = kSolarIlluminance * esra_diffuse_fraction(t, elevation) * twilight;
  zenith_Y_ *= shape_dhi > 0 ? diffuse_horizontal_ / shape_dhi : 0.0;

  if (elevation > 0) {
    const double m = air_mass(elevation);
    const double dni = kSolarIlluminance * std::exp(-0.8662 * t * m * rayleigh_thickness(m));
    const double beta = 0.04608 * t - 0.04586;  // Ångström turbidity coefficient (Preetham)
    Eigen::Vector3d transmittance;
    for (int c = 0; c < 3; ++c) {
      const double lambda = kChannelWavelength[static_cast<std::size_t>(c)];
      const double depth = 0.008735 * std::pow(lambda, -4.08) + beta * std::pow(lambda, -1.3);
      transmittance[c] = std::exp(-m * depth);
    }
    const double level = rgb_luminance(transmittance);
    if (level > 0) sun_.irradiance = transmittance * (dni / level);
  }
}

Vec3 ClearSky::sky_xyY(double cos_theta, double gamma, double cos_gamma) const {
  return {zenith_x_ * perez_x_(cos_theta, gamma, cos_gamma) / norm_x_,
          zenith_y_ * perez_y_(cos_theta, gamma, cos_gamma) / norm_y_,
          zenith_Y_ * perez_Y_(cos_theta, gamma, cos_gamma) / norm_Y_};
}

Eigen::Vector3d ClearSky::sky_radiance(const Vec3& site_direction) const {
  const double length = site_direction.norm();
  if (!(length > 0) || zenith_Y_ == 0) return Eigen::Vector3d::Zero();
  const Vec3 d = site_direction / length;
  if (d.z() <= 0) return Eigen::Vector3d::Zero();
  const double cos_gamma = std::clamp(d.dot(shape_sun_), -1.0, 1.0);
  const Vec3 xyY = sky_xyY(d.z(), std::acos(cos_gamma), cos_gamma);
  return xyY_to_linear_srgb(xyY.x(), xyY.y(), xyY.z());
}

Eigen::Vector3d ClearSky::radiance(const Vec3& site_direction) const {
  Eigen::Vector3d l = sky_radiance(site_direction);
  const double length = site_direction.norm();
  if (length > 0 && site_direction.z() > 0 && sun_.contains(site_direction / length)) l += sun_.radiance();
  return l;
}

OvercastSky::OvercastSky(double zenith_radiance) : zenith_radiance_(zenith_radiance) {
  if (!std::isfinite(zenith_radiance) || zenith_radiance <= 0) {
    throw InputError(input_message("", -1, -1, "zenith_radiance", "got " + std::to_string(zenith_radiance),
                                   "give a positive radiance (kcd/m²), e.g. 5"));
  }
}

Eigen::Vector3d OvercastSky::radiance(const Vec3& site_direction) const {
  const double length = site_direction.norm();
  if (!(length > 0) || site_direction.z() <= 0) return Eigen::Vector3d::Zero();
  const double cos_theta = site_direction.z() / length;
  return Eigen::Vector3d::Constant(zenith_radiance_ * (1.0 + 2.0 * cos_theta) / 3.0);
}

Eigen::Vector3d xyY_to_linear_srgb(double x, double y, double Y) {
  if (!(y > 0)) return Eigen::Vector3d::Zero();
  const double X = x / y * Y;
  const double Z = (1.0 - x - y) / y * Y;
  const Eigen::Vector3d rgb(3.2406 * X - 1.5372 * Y - 0.4986 * Z, -0.9689 * X + 1.8758 * Y + 0.0415 * Z,
                            0.0557 * X - 0.2040 * Y + 1.0570 * Z);
  return rgb.cwiseMax(0.0);
}

double rgb_luminance(const Eigen::Vector3d& rgb) { return 0.2126 * rgb.x() + 0.7152 * rgb.y() + 0.0722 * rgb.z(); }

}  // namespace skylit::sky
