#pragma once
// Analytic skies for simulation and tests: a clear sky (Preetham, Shirley, Smits 1999: Perez
// luminance distribution and xyY chromaticity, in linear sRGB) with a solar disc, and the CIE
// standard overcast sky.
#include <Eigen/Core>

namespace skylit::sky {

using Vec3 = Eigen::Vector3d;

// The sun's mean angular radius (0.2666°, i.e. a disc 0.53° wide), radians.
inline constexpr double kSunAngularRadius = 0.00465;

// Units: RGB radiance whose luminance (0.2126 R + 0.7152 G + 0.0722 B) is in kcd/m², the unit
// of Preetham's zenith luminance; irradiances are then in klx. Nothing downstream depends on
// the absolute scale, but the sun/sky ratio is physical (see ClearSky). Site frame: x east,
// y north, z up.
//
// A uniform solar disc: radiance irradiance / solid_angle() inside, 0 outside.
struct SunDisc {
  Vec3 direction = Vec3::UnitZ();                          // unit, site frame
  double angular_radius = kSunAngularRadius;               // radians
  Eigen::Vector3d irradiance = Eigen::Vector3d::Zero();    // ∫ L dω over the disc, RGB: the DNI
  double solid_angle() const;                              // 2π (1 − cos r)
  Eigen::Vector3d radiance() const { return irradiance / solid_angle(); }
  bool contains(const Vec3& unit_direction) const;
};

// Both skies (ClearSky, OvercastSky) are 0 below the horizon (no ground term: the sky camera's
// table leaves those pixels out anyway).
class ClearSky {
 public:
  // `sun_direction` (site frame, any length > 0) may be below the horizon: the sky then fades
  // linearly to black between elevation 0 and −6° (civil twilight), keeping the shape of a sun
  // on the horizon, and the disc is gone. Turbidity 2 (very clear) to 10 (hazy), the Preetham
  // model's range; 3 is a clear day. InputError naming 'turbidity' or 'sun_angular_radius'
  // (0 < r ≤ 0.1 rad) otherwise, std::invalid_argument for a zero or non-finite direction.
  explicit ClearSky(const Vec3& sun_direction, double turbidity = 3.0,
                    double sun_angular_radius = kSunAngularRadius);

  // Sky plus disc, linear RGB, 0 below the horizon. `site_direction` need not be unit length.
  Eigen::Vector3d radiance(const Vec3& site_direction) const;
  // The sky alone (Preetham), without the solar disc.
  Eigen::Vector3d sky_radiance(const Vec3& site_direction) const;
  // The disc. Levels follow the ESRA clear-sky model (Rigollier, Bauer, Wald 2000, Solar
  // Energy 68(1)) with Linke turbidity T_L = turbidity (Preetham's T is Linke's definition):
  //   DNI = E0 exp(−0.8662 T_L m δ_R(m))      m: Kasten–Young air mass, δ_R: Kasten's Rayleigh
  //                                           optical thickness, E0 = kSolarIlluminance
  //   DHI = E0 T_rd(T_L) F_d(elevation)        (the sky's diffuse horizontal irradiance)
  // The Preetham sky gives the shape and colour of the sky; its level is scaled so that
  // ∫ L cos θ dω = DHI (Preetham's own zenith luminance makes skies 2–3× too bright: a sun/sky
  // ratio of 3 where measurements give 6–10). The sun's colour is Preetham's attenuation per
  // channel (Rayleigh 0.008735 λ^−4.08, aerosol (0.04608 T − 0.04586) λ^−1.3, at λ = 0.61,
  // 0.55, 0.465 µm for R, G, B), scaled to the ESRA DNI in luminance. For T = 3 this gives
  // DNI ≈ 8.7 × DHI at elevations 30–60° (≈ 16 for T = 2, ≈ 4 for T = 5). Irradiance 0 when
  // the sun is below the horizon.
  const SunDisc& sun() const { return sun_; }

  const Vec3& sun_direction() const { return sun_.direction; }
  double turbidity() const { return turbidity_; }
  // The ESRA diffuse horizontal irradiance the sky is scaled to (klx; 0 after twilight).
  double diffuse_horizontal() const { return diffuse_horizontal_; }

  static constexpr double kSolarIlluminance = 133.8;  // klx above the atmosphere (Darula et al. 2005)

 private:
  struct Perez {
    double a, b, c, d, e;
    double operator()(double cos_theta, double gamma, double cos_gamma) const;
  };
  Vec3 sky_xyY(double cos_theta, double gamma, double cos_gamma) const;

  double turbidity_;
  SunDisc sun_;
  Vec3 shape_sun_;          // the sun used for the sky's shape (lifted onto the horizon at night)
  Perez perez_Y_{}, perez_x_{}, perez_y_{};
  double zenith_Y_ = 0, zenith_x_ = 0, zenith_y_ = 0;
  double norm_Y_ = 1, norm_x_ = 1, norm_y_ = 1;   // F(0, θs) per quantity
  double diffuse_horizontal_ = 0;
};

// CIE standard overcast sky (Moon and Spencer 1942): L(θ) = L_z (1 + 2 cos θ) / 3, grey, 0 below
// the horizon, so L(zenith) / L(horizon) = 3 and the diffuse horizontal irradiance is 7π/9 L_z.
class OvercastSky {
 public:
  // InputError naming 'zenith_radiance' unless it is finite and > 0.
  explicit OvercastSky(double zenith_radiance = 5.0);
  Eigen::Vector3d radiance(const Vec3& site_direction) const;
  double zenith_radiance() const { return zenith_radiance_; }

 private:
  double zenith_radiance_;
};

// sRGB (D65) linear RGB of CIE xyY; negative components (outside the sRGB gamut) clamped to 0.
Eigen::Vector3d xyY_to_linear_srgb(double x, double y, double Y);
// Rec. 709 / sRGB luminance of linear RGB.
double rgb_luminance(const Eigen::Vector3d& rgb);

}  // namespace skylit::sky
