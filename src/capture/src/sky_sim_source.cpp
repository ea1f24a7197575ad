// The sky simulator as a frame source: skylit/sky/simulate.hpp rendered through a calibration.
#include <cmath>
#include <cstdio>
#include <numbers>

#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"
#include "skylit/capture/sources.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/solar.hpp"
#include "skylit/geom/angles.hpp"

namespace skylit::capture {
namespace {

using geom::kDeg;
namespace fs = std::filesystem;

[[noreturn]] void bad_setting(const std::string& field, const std::string& problem, const std::string& fix) {
  throw InputError(input_message("", -1, -1, field, problem, fix));
}

sky::AnalyticSkySettings analytic_settings(const SkySimSettings& settings) {
  sky::AnalyticSkySettings analytic;
  analytic.kind = settings.sky == SkySimSettings::Sky::Overcast ? sky::AnalyticSkySettings::Kind::Overcast
                                                               : sky::AnalyticSkySettings::Kind::Clear;
  analytic.turbidity = settings.turbidity;
  analytic.zenith_radiance = settings.zenith_radiance;
  analytic.latitude_deg = settings.latitude_deg;
  analytic.longitude_deg = settings.longitude_deg;
  return analytic;
}

bool positive(double value) { return std::isfinite(value) && value > 0; }

}  // namespace

SkySimSource::SkySimSource(const SkySimSettings& settings, FrameChecks checks)
    : FrameSource(checks), settings_(settings) {
  if (settings_.supersample < 1 || settings_.supersample > 16) {
    bad_setting("supersample", "got " + std::to_string(settings_.supersample) + ", outside 1..16",
                "use 1 (fast) to 4 (smooth)");
  }
  if (settings_.step.count() < 1) bad_setting("every", "the time step is under a second", "give e.g. 10min");
  if (settings_.frames < 0) bad_setting("frames", "negative", "give how many frames, or 0 for no end");
  if (settings_.exposure_time && !positive(*settings_.exposure_time)) {
    bad_setting("exposure_time", "not a positive number", "give seconds, e.g. 0.1, or leave it out for float frames");
  }
  if (!positive(settings_.gain)) bad_setting("gain", "not a positive number", "give a linear gain, e.g. 1");
  if (!std::isfinite(settings_.azimuth_offset_deg)) bad_setting("azimuth_offset", "not a number", "give degrees, e.g. 90");
  lens_ = std::make_unique<camera::Lens>(camera::load_calibration(settings_.calibration));
  if (settings_.sky == SkySimSettings::Sky::Equirect) {
    sky::RenderOptions options;
    options.supersample = settings_.supersample;
    options.azimuth_offset = settings_.azimuth_offset_deg * kDeg;
    equirect_render_ = sky::render_fisheye(*lens_, sky::read_equirect(settings_.equirect), options);
  } else {
    // The sky models check turbidity, radiance, latitude and longitude now, not at frame 1.
    (void)sky::analytic_sky(analytic_settings(settings_), settings_.start);
  }
}

SkySimSource::~SkySimSource() = default;

std::string SkySimSource::describe() const {
  switch (settings_.sky) {
    case SkySimSettings::Sky::Clear: {
      char place[64];
      std::snprintf(place, sizeof place, "%.4f, %.4f", settings_.latitude_deg, settings_.longitude_deg);
      return "sky-sim clear sky at " + std::string(place) + " from " + sky::format_utc(settings_.start);
    }
    case SkySimSettings::Sky::Overcast:
      return "sky-sim overcast sky";
    case SkySimSettings::Sky::Equirect:
      break;
  }
  return "sky-sim " + settings_.equirect.string();
}

bool SkySimSource::set_exposure_time(double seconds) {
  if (!positive(seconds)) return false;
  settings_.exposure_time = seconds;
  return true;
}

bool SkySimSource::set_gain(double gain) {
  if (!positive(gain)) return false;
  settings_.gain = gain;
  return true;
}

std::chrono::sys_seconds SkySimSource::utc_of(std::int64_t k) const { return settings_.start + k * settings_.step; }

cv::Mat SkySimSource::render(std::int64_t k) const {
  if (settings_.sky == SkySimSettings::Sky::Equirect) return equirect_render_.clone();
  sky::RenderOptions options;
  options.supersample = settings_.supersample;
  return sky::render_fisheye(*lens_, sky::analytic_sky(analytic_settings(settings_), utc_of(k)), options);
}

Frame SkySimSource::make_frame(const cv::Mat& radiance, std::int64_t k, std::optional<double> exposure_time) const {
  Frame frame;
  if (exposure_time) {
    frame.image = sky::to_8bit(radiance, *exposure_time * settings_.gain);
    frame.exposure_time = exposure_time;
    frame.gain = settings_.gain;
  } else {
    frame.image = radiance;
  }
  frame.timestamp = static_cast<double>(k) * static_cast<double>(settings_.step.count());
  if (settings_.sky != SkySimSettings::Sky::Equirect) frame.utc = utc_of(k);
  return frame;
}

FrameResult SkySimSource::read(double /*timeout_s*/) {
  if (settings_.frames > 0 && next_ >= settings_.frames) return {FrameStatus::EndOfStream, {}};
  const std::int64_t k = next_++;
  Frame frame = make_frame(render(k), k, settings_.exposure_time);
  frame.sequence = sequence_++;
  return {FrameStatus::Ready, std::move(frame)};
}

std::optional<std::vector<Frame>> SkySimSource::read_bracket(std::span<const double> exposure_times_s,
                                                             double /*timeout_s*/) {
  std::vector<Frame> frames;
  if (settings_.frames > 0 && next_ >= settings_.frames) return frames;
  const std::int64_t k = next_++;
  const cv::Mat radiance = render(k);
  for (const double time : exposure_times_s) {
    if (!positive(time)) {
      bad_setting("exposure_time", "a bracket exposure of " + std::to_string(time) + " s",
                  "give positive exposure times in seconds");
    }
    Frame frame = make_frame(radiance, k, time);
    frame.sequence = sequence_++;
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace skylit::capture
