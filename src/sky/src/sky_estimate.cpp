#include "skylit/sky/sky_estimate.hpp"

#include <algorithm>
#include <chrono>

#include <opencv2/imgcodecs.hpp>

#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/sky_model.hpp"

namespace skylit::sky {
namespace {

double milliseconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

cv::Mat load_calibration_mask(const camera::CameraCalibration& calibration) {
  if (calibration.mask.empty()) return {};
  cv::Mat mask = read_image(calibration.mask, cv::IMREAD_GRAYSCALE);
  if (mask.empty()) {
    throw InputError(input_message(calibration.file, -1, -1, "mask",
                                   "cannot read the sky mask " + calibration.mask.string(),
                                   "give a PNG (0 where the mount hides the sky) next to the calibration, "
                                   "or remove the field"));
  }
  if (mask.cols != calibration.image_width || mask.rows != calibration.image_height) {
    throw InputError(input_message(calibration.file, -1, -1, "mask",
                                   "the sky mask " + calibration.mask.string() + " is " + std::to_string(mask.cols) +
                                       "×" + std::to_string(mask.rows) + ", the images are " +
                                       std::to_string(calibration.image_width) + "×" +
                                       std::to_string(calibration.image_height),
                                   "draw the mask on a frame of this camera"));
  }
  return mask;
}

SkyEstimator::SkyEstimator(const camera::CameraCalibration& calibration, const geom::Dome& dome, SkyEstimateOptions options)
    : lens_(calibration), dome_(dome), options_(options), mask_(load_calibration_mask(calibration)) {
  table_ = build_sky_table(lens_, dome_, mask_, options_.table);
  if (options_.max_sources < 1) {
    throw InputError(input_message({}, -1, -1, "max_sources",
                                   "value " + std::to_string(options_.max_sources) + " is below 1",
                                   "use 1 for the sun alone, or more to separate further compact sources"));
  }
  if (options_.sun_mode == SunMode::Auto) {
    sun_detector_.emplace(lens_, mask_, options_.sun);
    if (options_.max_sources > 1) lamp_detector_.emplace(lens_, mask_, options_.lamp);
  }
}

ClippedSunEnergy parse_clipped_sun_energy(const std::string& text, const std::string& field) {
  if (text == "measured") return ClippedSunEnergy::Measured;
  if (text == "clear_sky") return ClippedSunEnergy::ClearSky;
  if (text == "shadow_contrast") return ClippedSunEnergy::ShadowContrast;
  throw InputError(input_message({}, -1, -1, field, "got '" + text + "'",
                                 "use clear_sky (a clear-sky model fitted to the unclipped sky), shadow_contrast (the "
                                 "HMD camera's ground in and out of a real shadow) or measured (the clipped pixels: a "
                                 "lower bound)"));
}

void SkyEstimator::estimate_clipped_sun_energy(Sun& sun, const RadianceFrame& frame, const cv::Mat& disc) const {
  const std::optional<ClearSkyFit> fit =
      fit_clear_sky(lens_, sun_detector_->sky(), frame.radiance, frame.clipped, disc, sun.direction, options_.clear_sky);
  if (!fit) return;
  // A clear sky far from the sun says nothing of a cloud on it: the sun's own surroundings must
  // glow as a clear aureole does.
  const std::optional<double> glow =
      circumsolar_glow(lens_, sun_detector_->sky(), frame.radiance, frame.clipped, disc, sun.direction);
  const ClearSkyFitOptions& o = options_.clear_sky;
  const double clear_around = glow ? std::clamp((*glow - o.cloudy_glow) / (o.clear_glow - o.cloudy_glow), 0.0, 1.0) : 1.0;
  const double confidence = fit->confidence * clear_around;
  const Eigen::Vector3d estimated = confidence * fit->sun_energy;

  if (!(rgb_luminance(estimated) > rgb_luminance(sun.energy))) return;  // the pixels already say more
  sun.measured_energy = sun.energy;
  sun.energy = estimated;
  sun.energy_estimator = "clear_sky";
  sun.energy_confidence = confidence;
}

SkyEstimate SkyEstimator::estimate(const RadianceFrame& frame, const std::optional<Vec3>& expected_sun) const {
  SkyEstimate result;
  cv::Mat exclude;
  if (sun_detector_) {
    const auto start = std::chrono::steady_clock::now();
    SunDetection detection = sun_detector_->detect(frame.radiance, frame.clipped, expected_sun);
    if (detection.sun && detection.sun->clipped && options_.clipped_sun_energy == ClippedSunEnergy::ClearSky) {
      estimate_clipped_sun_energy(*detection.sun, frame, detection.mask);
    }
    if (detection.sun && options_.correct_sun_colour) correct_sun_colour(*detection.sun);
    result.sun = detection.sun;
    result.sun_reason = detection.reason;
    exclude = detection.mask;
    if (detection.sun) result.sources.push_back(*detection.sun);
    if (lamp_detector_) {
      // Detect, set the disc to its background (and no longer clipped), detect again.
      cv::Mat working = frame.radiance.clone();
      cv::Mat clipped = frame.clipped.empty() ? cv::Mat() : frame.clipped.clone();
      if (exclude.empty()) exclude = cv::Mat(frame.radiance.size(), CV_8UC1, cv::Scalar(0));
      const auto remove = [&](const Sun& source, const cv::Mat& disc) {
        working.setTo(cv::Vec3f(static_cast<float>(source.background.z()), static_cast<float>(source.background.y()),
                                static_cast<float>(source.background.x())),
                      disc);
        if (!clipped.empty()) clipped.setTo(0, disc);
        exclude.setTo(255, disc);
      };
      if (detection.sun) remove(*detection.sun, detection.mask);
      result.sources_reason = "max_sources reached";
      while (result.sources.size() < static_cast<std::size_t>(options_.max_sources)) {
        const SunDetection found = lamp_detector_->detect(working, clipped);
        if (!found.sun) {
          result.sources_reason = found.reason;
          break;
        }
        result.sources.push_back(*found.sun);
        remove(*found.sun, found.mask);
      }
    }
    result.sun_ms = milliseconds_since(start);
  } else {
    result.sun_reason = "sun separation off";
  }
  const auto start = std::chrono::steady_clock::now();
  result.luminance = compute_luminance(table_, dome_, frame.radiance, frame.clipped, exclude, options_.luminance);
  result.luminance_ms = milliseconds_since(start);
  return result;
}

}  // namespace skylit::sky
