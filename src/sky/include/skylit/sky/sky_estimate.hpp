#pragma once
// The sky stage in one object: from a linear radiance frame to luminance parameters S_i and,
// under a clear sky, a separate sun. Built once per calibration and dome (it owns the sky table
// and the sun detector); then one call per sky frame.
#include <optional>
#include <string>

#include "skylit/geom/dome.hpp"
#include "skylit/sky/calibration.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_table.hpp"
#include "skylit/sky/sun.hpp"

namespace skylit::sky {

enum class SunMode { Off, Auto };

struct SkyEstimateOptions {
  SkyTableOptions table;
  LuminanceOptions luminance;
  SunMode sun_mode = SunMode::Auto;
  SunOptions sun;
};

struct SkyEstimate {
  Luminance luminance;              // S_i (with the sun's pixels taken out when a sun is found)
  std::optional<Sun> sun;
  std::string sun_reason;           // why there is (no) sun; "sun separation off" when off
  double luminance_ms = 0;
  double sun_ms = 0;
};

class SkyEstimator {
 public:
  // Reads calibration.mask when it names a file (InputError naming the calibration otherwise).
  SkyEstimator(const CameraCalibration& calibration, const geom::Dome& dome, SkyEstimateOptions options = {});
  SkyEstimator(const SkyEstimator&) = delete;
  SkyEstimator& operator=(const SkyEstimator&) = delete;

  SkyEstimate estimate(const RadianceFrame& frame) const;

  const Lens& lens() const { return lens_; }
  const SkyTable& table() const { return table_; }
  const geom::Dome& dome() const { return dome_; }
  const SkyEstimateOptions& options() const { return options_; }

 private:
  Lens lens_;
  const geom::Dome& dome_;
  SkyEstimateOptions options_;
  cv::Mat mask_;
  SkyTable table_;
  std::optional<SunDetector> sun_detector_;
};

// The mask named by a calibration (CV_8U, image size), or an empty Mat when it names none.
// InputError naming the calibration file and the field `mask` when unreadable or mis-sized.
cv::Mat load_calibration_mask(const CameraCalibration& calibration);

}  // namespace skylit::sky
