#include "sky_stage.hpp"

#include <chrono>

#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"

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

SkyStage::Result SkyStage::estimate(const capture::Frame& frame) { return estimate(std::span(&frame, 1)); }

SkyStage::Result SkyStage::estimate(std::span<const capture::Frame> frames) {
  if (frames.empty()) throw std::invalid_argument("SkyStage::estimate: no frame");
  const capture::Frame& frame = frames.front();
  const auto start = std::chrono::steady_clock::now();
  const auto exposure_of = [](const capture::Frame& f) {
    sky::Exposure exposure;
    if (f.exposure_time) exposure.time_s = *f.exposure_time;
    if (f.gain) exposure.gain = *f.gain;
    return exposure;
  };
  const int bits = frame.image.depth() == CV_16U ? 16 : 8;
  Result r;
  if (frames.size() == 1) {
    r.radiance = frame.image.depth() == CV_32F
                     ? sky::linearise(frame.image, sky::ResponseCurve::linear(8), exposure_of(frame))
                     : sky::linearise(frame.image, sky::response_for(response_, bits), exposure_of(frame));
  } else {
    std::vector<cv::Mat> images;
    std::vector<sky::Exposure> exposures;
    for (const capture::Frame& f : frames) {
      if (!f.exposure_time) {
        throw InputError(input_message({}, -1, -1, "sky.bracket",
                                       "a bracket frame from " + f.source + " does not say its exposure time",
                                       "bracket with a source that reports it (libcamera, sky-sim), or remove sky.bracket"));
      }
      images.push_back(f.image);
      exposures.push_back(exposure_of(f));
    }
    r.radiance = sky::merge_bracket(images, exposures, sky::response_for(response_, bits));
  }
  std::optional<sky::Vec3> expected_sun;
  if (location_ && frame.utc) {
    expected_sun = sky::solar_position(*frame.utc, location_->latitude_deg, location_->longitude_deg).direction();
  }
  r.estimate = smoother_.smooth(frame.timestamp, estimator_->estimate(r.radiance, expected_sun));
  r.estimate_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return r;
}

SkyFrames next_sky_frames(capture::FrameSource& source, std::span<const double> bracket, double timeout_s,
                          bool& bracket_unsupported) {
  SkyFrames sky;
  if (!bracket.empty() && !bracket_unsupported) {
    std::optional<std::vector<capture::Frame>> frames = source.bracket(bracket, timeout_s);
    if (frames && !frames->empty()) {
      // A bracket short of a frame (one dropped as malformed) is still merged.
      sky.status = capture::FrameStatus::Ready;
      sky.frames = std::move(*frames);
      return sky;
    }
    if (frames) {
      // No frame: the source timed out, or a finite one has ended (which next() says).
      sky.status = source.next(0.0).status == capture::FrameStatus::EndOfStream ? capture::FrameStatus::EndOfStream
                                                                                : capture::FrameStatus::NotYet;
      return sky;
    }
    bracket_unsupported = true;
  }
  capture::FrameResult result = source.next(timeout_s);
  sky.status = result.status;
  if (result.status == capture::FrameStatus::Ready) sky.frames.push_back(std::move(result.frame));
  return sky;
}

}  // namespace skylit::live
