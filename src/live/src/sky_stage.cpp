#include "sky_stage.hpp"

#include <chrono>

#include <opencv2/core.hpp>

#include "skylit/sky/solar.hpp"

namespace skylit::live {
namespace {

sky::SkyEstimateOptions estimate_options(geom::DomeBasis basis, const SkySettings& settings) {
  sky::SkyEstimateOptions options;
  options.sun_mode = settings.sun ? sky::SunMode::Auto : sky::SunMode::Off;
  options.table.basis = basis;
  options.max_sources = settings.max_sources;
  options.correct_sun_colour = settings.correct_sun_colour;
  options.clipped_sun_energy = settings.clipped_sun_energy;
  return options;
}

}  // namespace

SkyStage::SkyStage(const camera::CameraCalibration& calibration, const geom::Dome& dome, geom::DomeBasis basis,
                   const SkySettings& settings, const std::optional<scene::GeoLocation>& location)
    : response_(settings.response),
      location_(location),
      estimator_(std::make_unique<sky::SkyEstimator>(calibration, dome, estimate_options(basis, settings))),
      smoother_(settings.smoothing) {}

SkyStage::Result SkyStage::estimate(const capture::Frame& frame) {
  const auto start = std::chrono::steady_clock::now();
  sky::Exposure exposure;
  if (frame.exposure_time) exposure.time_s = *frame.exposure_time;
  if (frame.gain) exposure.gain = *frame.gain;
  const int bits = frame.image.depth() == CV_16U ? 16 : 8;
  Result r;
  r.radiance = frame.image.depth() == CV_32F ? sky::linearise(frame.image, sky::ResponseCurve::linear(8), exposure)
                                              : sky::linearise(frame.image, sky::response_for(response_, bits), exposure);
  std::optional<sky::Vec3> expected_sun;
  if (location_ && frame.utc) {
    expected_sun = sky::solar_position(*frame.utc, location_->latitude_deg, location_->longitude_deg).direction();
  }
  r.estimate = smoother_.smooth(frame.timestamp, estimator_->estimate(r.radiance, expected_sun));
  r.estimate_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace skylit::live
