#pragma once
// The sky stage in one object: from a linear radiance frame to luminance parameters S_i and,
// under a clear sky, a separate sun; optionally further separated compact sources (lamps). Built once per calibration and dome (it owns the sky table
// and the sun detector); then one call per sky frame.
#include <optional>
#include <string>
#include <vector>

#include "skylit/geom/dome.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/clear_sky_fit.hpp"
#include "skylit/sky/sun.hpp"

namespace skylit::sky {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

enum class SunMode { Off, Auto };

// ShadowContrast is the HMD node's: the sky stage keeps the measured energy, and the node replaces
// it from the real ground in and out of a real shadow (render::estimate_sun_from_shadow_contrast).
enum class ClippedSunEnergy { Measured, ClearSky, ShadowContrast };
// "measured" | "clear_sky" | "shadow_contrast"; InputError naming `field` and the choices otherwise.
ClippedSunEnergy parse_clipped_sun_energy(const std::string& text, const std::string& field);

struct SkyEstimateOptions {
  SkyTableOptions table;
  LuminanceOptions luminance;
  SunMode sun_mode = SunMode::Auto;
  SunOptions sun;
  // Separated sources at most (with sun_mode Auto). 1: the sun alone (when there is one). N > 1:
  // after the sun test, the detector looks again up to N − 1 more times with `lamp` options, each
  // found source's disc set to its background first (detect → remove → detect again); when the
  // sun test fails the first lamp is the brightest compact source. Every source's disc is left
  // out of S, and each is its own separated term (blend::blend_weights with several SunLights).
  // Indoors (many ceiling lamps) 16 sources bring the warehouse from 0.0231 to 0.0086 RMS
  // (bench/RESULTS.md, "Separated sources (issue 3)").
  int max_sources = 1;
  SunOptions lamp = lamp_options();
  // A sun (not a lamp) whose colour is impossible for daylight gets a clear sky's sun colour at
  // its elevation (correct_sun_colour, flagged Sun::colour_corrected). Off where the frame's sun
  // must be taken as it is (a study against a reference made from the same capture).
  bool correct_sun_colour = true;
  // A clipped sun's energy (an 8-bit camera clips it in every clear frame): Measured keeps what
  // its pixels say (a lower bound); ClearSky takes the sun of a clear-sky model fitted to the
  // unclipped sky (clear_sky_fit.hpp), times the fit's confidence, when that is more. Measured by
  // default: on the real skies the model's sun overshoots hazy ones (bench/RESULTS.md, "The sun
  // through an 8-bit camera").
  ClippedSunEnergy clipped_sun_energy = ClippedSunEnergy::Measured;
  ClearSkyFitOptions clear_sky;
};

struct SkyEstimate {
  Luminance luminance;              // S_i (with the sun's pixels taken out when a sun is found)
  std::optional<Sun> sun;           // the first source when it passes the sun's tests
  std::string sun_reason;           // why there is (no) sun; "sun separation off" when off
  // Every separated source, in the order found (brightest first): sources[0] is `sun` when there
  // is a sun; with max_sources 1 this is `sun` or nothing. A consumer that takes only `sun`
  // must run with max_sources 1, since S lacks every source's disc (the live service takes them
  // all: sky.max_sources; its smoothing smooths the sun's energy, not the lamps').
  std::vector<Sun> sources;
  std::string sources_reason;       // why the search for further sources stopped (max_sources > 1)
  double luminance_ms = 0;
  double sun_ms = 0;
};

class SkyEstimator {
 public:
  // Reads calibration.mask when it names a file (InputError naming the calibration otherwise).
  SkyEstimator(const camera::CameraCalibration& calibration, const geom::Dome& dome, SkyEstimateOptions options = {});
  SkyEstimator(const SkyEstimator&) = delete;
  SkyEstimator& operator=(const SkyEstimator&) = delete;

  // `expected_sun`: where the site's location and the frame's time put the sun (unit, site
  // frame), or nullopt: a clipped blob there is the sun however wide (SunDetector::detect).
  SkyEstimate estimate(const RadianceFrame& frame, const std::optional<Vec3>& expected_sun = std::nullopt) const;

  const camera::Lens& lens() const { return lens_; }
  const SkyTable& table() const { return table_; }
  const geom::Dome& dome() const { return dome_; }
  const SkyEstimateOptions& options() const { return options_; }

 private:
  // A clipped sun's energy from a clear-sky model fitted to the rest of the frame (disc: the
  // sun's pixels, left out of the fit).
  void estimate_clipped_sun_energy(Sun& sun, const RadianceFrame& frame, const cv::Mat& disc) const;
  camera::Lens lens_;
  const geom::Dome& dome_;
  SkyEstimateOptions options_;
  cv::Mat mask_;
  SkyTable table_;
  std::optional<SunDetector> sun_detector_;
  std::optional<SunDetector> lamp_detector_;   // max_sources > 1
};

// The mask named by a calibration (CV_8U, image size), or an empty Mat when it names none.
// InputError naming the calibration file and the field `mask` when unreadable or mis-sized.
cv::Mat load_calibration_mask(const camera::CameraCalibration& calibration);

}  // namespace skylit::sky
