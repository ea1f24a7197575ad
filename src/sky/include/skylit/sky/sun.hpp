#pragma once
// The sun in a sky frame: found when it is a compact source far brighter than the sky around
// it (a clear sky), absent otherwise (overcast: forcing a sun there makes shadows worse).
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/lens.hpp"

namespace skylit::sky {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Under a clear sky most of the light comes from a disc 0.5° wide that a 40-face dome would
// move up to ~15° to a face centre. A detected sun is taken out of the dome (its pixels are
// excluded from the luminance parameters) and returned as a directional light:
//
//     E_sun = Σ_p w_p (L_p − L_background)     over the disc's pixels, per channel
//
// the irradiance it gives a surface that faces it, in the same relative units as S.
struct Sun {
  Vec3 direction = Vec3::UnitZ();                        // unit, site frame, towards the sun
  double angular_radius = 0;                             // radians, of the disc's core (over half the peak)
  // Radians: the uniform disc whose spread is the disc's (√2 × the energy-weighted RMS angle of
  // its pixels from `direction`), the disc a shadow map draws for it. An extended lamp's core
  // says little of how soft its shadows are; this matches them (bench/RESULTS.md, "Every
  // separated source on the GPU": the warehouse 0.0165 → 0.0096 on the GPU path).
  double shadow_radius = 0;
  Eigen::Vector3d energy = Eigen::Vector3d::Zero();      // E_sun, RGB
  Eigen::Vector3d background = Eigen::Vector3d::Zero();  // sky radiance around it, RGB
  double contrast = 0;          // peak luminance / background luminance (inf on a black sky)
  int pixel_count = 0;          // pixels of the disc
  bool clipped = false;         // some disc pixels clipped: E_sun is a lower bound
  // The disc as an area light, for soft shadows: unit directions and their share of E_sun (sum
  // 1), the disc's pixels merged into at most ~kMaxDiscSamples cells. A real sun is 0.5° wide
  // and casts a penumbra; a hazy or blurred one, a wider one.
  std::vector<Vec3> disc_directions;
  std::vector<double> disc_weights;
  // The energy's colour was impossible for daylight (a lossy capture that kept one channel of the
  // disc) and was replaced by daylight_sun_colour at its elevation (correct_sun_colour):
  // measured_energy is what the pixels said.
  bool colour_corrected = false;
  Eigen::Vector3d measured_energy = Eigen::Vector3d::Zero();
  // Where it was found: "peak" (a compact bright source), "expected" (a clipped blob around where
  // the site's location and the frame's time put the sun) or "clipped shape" (a round clipped
  // blob, without a time).
  std::string located_by = "peak";
  // How its energy was found: "measured" (its pixels; a lower bound when clipped) or "clear_sky"
  // (clipped: the sun of a clear-sky model fitted to the unclipped sky, times the fit's
  // confidence; see clear_sky_fit.hpp), and how sure that is (0 to 1; 1 for a measured sun
  // that nothing clipped).
  std::string energy_estimator = "measured";
  double energy_confidence = 1.0;
};

// The sun's colour through a clear atmosphere, in linear sRGB with the largest channel 1: a
// 5800 K sun at 610, 550 and 465 nm, dimmed by Rayleigh and aerosol extinction (Ångström β 0.1,
// α 1.3) along the air mass at `elevation` (radians; Kasten–Young): about (1, 1, 0.87) overhead,
// (1, 0.75, 0.32) 10° up.
Eigen::Vector3d daylight_sun_colour(double elevation);

// Whether an energy's colour could be daylight's, from a setting sun (1, 0.2, 0) to a sun bluer
// than any (about 10 000 K): green at least 0.2 of red, red at least 0.7 of green and blue at most
// 1.3 × green. Zero or non-finite: not.
bool plausible_sun_colour(const Eigen::Vector3d& energy);

// A sun whose colour is not plausible gets daylight_sun_colour at its elevation, its brightest
// channel at the brightest measured one (the channel the capture kept), and colour_corrected;
// any other is left as it is. Returns whether it changed.
bool correct_sun_colour(Sun& sun);

inline constexpr int kMaxDiscSamples = 256;

struct SunOptions {
  double min_contrast = 20;             // peak / background luminance for a sun to count
  double max_angular_radius_deg = 3.0;  // a core (over half the peak) wider than this: no compact sun
  double background_inner_deg = 6.0;    // annulus around the peak that measures the background
  double background_outer_deg = 15.0;
  // Disc pixels: luminance > background × disc_factor, connected, and within halo_radius of the
  // peak. The glow fainter than 10× the background stays in the dome: taken into the sun term
  // it blurs the sun's shadows (park, bench/RESULTS.md "Accuracy of the sky stage": RMS 0.0132 at 3×, 0.0107 at
  // 10×; no other sky changed), and the dome carries a glow a few degrees wide well.
  double disc_factor = 10.0;
  double halo_radius_deg = 5.0;
  // A clipped sun: an 8-bit camera clips the sun and the sky around it into a blob several
  // degrees wide (5–8° at 18% exposure), no compact core. Such a blob is the sun when it lies
  // within expected_tolerance_deg of where the sun is expected (location and time), or, without
  // an expectation, when it is round (its solid angle at least min_clipped_roundness of the disc
  // that holds it); either way no wider than max_clipped_radius_deg (beyond: an overexposed sky).
  double max_clipped_radius_deg = 12.0;
  double expected_tolerance_deg = 4.0;
  double min_clipped_roundness = 0.5;
};

// The detector's mode for further compact sources (lamps under a ceiling, a second light): the
// sun's tests relaxed as in the "Separated sources (issue 3)" diagnosis of bench/RESULTS.md: the
// brightest compact source, whatever its contrast (min_contrast 1), its core up to 15° wide. The
// disc (pixels over disc_factor × background, within halo_radius) is the sun's.
inline SunOptions lamp_options(SunOptions base = {}) {
  base.min_contrast = 1.0;
  base.max_angular_radius_deg = 15.0;
  return base;
}

struct SunDetection {
  std::optional<Sun> sun;
  std::string reason;   // why there is no sun (or "compact sun" when there is one)
  cv::Mat mask;         // CV_8U, frame size, 255 on the disc's pixels (empty without a sun)
};

// Built once per calibration: which pixels see the sky (above the horizon, not masked).
class SunDetector {
 public:
  // `mask`: CV_8U image-sized, 0 = hidden; may be empty (calibration.mask is not read here).
  SunDetector(const camera::Lens& lens, const cv::Mat& mask, SunOptions options = {});

  // `radiance`: CV_32FC3 BGR linear (non-finite and negative values count as 0); `clipped`:
  // CV_8U (255 = clipped) or empty. InputError when sizes or types do not match the lens.
  // `expected`: where the sun should be (unit, site frame: sun_direction_at for the frame's time
  // and the site's location), or nullopt when the frame has no time or the site no location.
  SunDetection detect(const cv::Mat& radiance, const cv::Mat& clipped,
                      const std::optional<Vec3>& expected = std::nullopt) const;
  // 255 where a pixel sees the sky (above the horizon, not masked).
  const cv::Mat& sky() const { return sky_; }

  const SunOptions& options() const { return options_; }

 private:
  const camera::Lens* lens_;
  SunOptions options_;
  cv::Mat sky_;   // CV_8U, 255 where the pixel sees the sky
};

}  // namespace skylit::sky
