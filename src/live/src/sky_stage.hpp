#pragma once
// The sky stage: a sky frame → radiance → S and the separated sun, smoothed over time. One code
// path for skylit-live's sky thread and skylit-sky-node, so that a sky published over the link is
// the one the service would have estimated in-process.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "skylit/camera/calibration.hpp"
#include "skylit/capture/frame_source.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/live/live_config.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/scene/site.hpp"
#include "skylit/sky/sky_estimate.hpp"
#include "skylit/sky/sky_smoothing.hpp"

namespace skylit::live {

class SkyStage {
 public:
  struct Result {
    sky::RadianceFrame radiance;  // what the overlay is drawn from
    sky::SkyEstimate estimate;    // smoothed
    double estimate_ms = 0;       // linearise, estimate and smooth
  };

  // InputError for a calibration whose mask cannot be read, or a bad smoothing constant.
  // `location`: the site's; with a frame's time it says where the sun is, so that a clipped blob
  // there is taken as the sun however wide (sky::SunDetector).
  SkyStage(const camera::CameraCalibration& calibration, const geom::Dome& dome, geom::DomeBasis basis,
           const SkySettings& settings, const std::optional<scene::GeoLocation>& location = std::nullopt);

  Result estimate(const capture::Frame& frame);
  // A bracket (sky.bracket): its 8/16-bit frames merged to one radiance frame by their exposure
  // times (sky::merge_bracket, the frames' response), then as one frame; its time is the first
  // frame's. One frame: estimate(frame). InputError for a frame without its exposure time.
  Result estimate(std::span<const capture::Frame> frames);
  const sky::SkyEstimator& estimator() const { return *estimator_; }

 private:
  std::string response_;
  std::optional<scene::GeoLocation> location_;
  std::unique_ptr<sky::SkyEstimator> estimator_;
  sky::SkySmoother smoother_;
};

// The next sky's frames: one frame, or with `bracket` one per exposure time (FrameSource::bracket).
// A source that cannot bracket gives single frames and sets `bracket_unsupported`.
struct SkyFrames {
  capture::FrameStatus status = capture::FrameStatus::NotYet;
  std::vector<capture::Frame> frames;
};
SkyFrames next_sky_frames(capture::FrameSource& source, std::span<const double> bracket, double timeout_s,
                          bool& bracket_unsupported);

}  // namespace skylit::live
