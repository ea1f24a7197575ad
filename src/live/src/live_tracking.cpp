#include "live_tracking.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <opencv2/core.hpp>

#include "skylit/camera/lens.hpp"

namespace skylit::live {
namespace {

nlohmann::json pose_json(const track::Pose& pose) {
  const Eigen::Quaterniond& q = pose.R_site_from_camera;
  const Eigen::Vector3d& t = pose.t_site_from_camera;
  return {{"timestamp", pose.timestamp}, {"position", {t.x(), t.y(), t.z()}}, {"orientation", {q.w(), q.x(), q.y(), q.z()}}};
}

double finite_or_infinity(double value) {
  return std::isfinite(value) ? value : std::numeric_limits<double>::infinity();
}

}  // namespace

cv::Mat tracker_image(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  cv::Mat codes;
  if (image.depth() == CV_16U) {
    image.convertTo(codes, CV_8U, 1.0 / 257.0);
  } else {
    cv::Mat clipped;
    cv::min(cv::max(image, 0.0), 1.0, clipped);
    clipped.convertTo(codes, CV_8U, 255.0);
  }
  return codes;
}

double BuildingFade::next(bool has_pose, double timestamp) {
  // Frame time since the last frame; a clock that steps back (a recording looping) counts as none.
  const double elapsed = last_timestamp_ ? std::max(0.0, timestamp - *last_timestamp_) : 0.0;
  last_timestamp_ = timestamp;
  const double step = fade_s_ > 0.0 ? elapsed / fade_s_ : std::numeric_limits<double>::infinity();
  double opacity = opacity_.load();
  State state = state_.load();
  if (has_pose) {
    if (state == State::NoPoseYet || (had_pose_ && state == State::Shown) || fade_s_ <= 0.0) {
      opacity = 1.0;
    } else if (!had_pose_) {
      opacity = 0.0;  // a pose back after a loss: at its own place, from nothing
    } else {
      opacity = std::min(1.0, opacity + step);
    }
    state = opacity >= 1.0 ? State::Shown : State::FadingIn;
  } else if (state != State::NoPoseYet) {
    opacity = std::max(0.0, opacity - step);
    state = opacity <= 0.0 ? State::Hidden : State::FadingOut;
  }
  had_pose_ = has_pose;
  opacity_ = opacity;
  state_ = state;
  return opacity;
}

std::string to_string(BuildingFade::State state) {
  switch (state) {
    case BuildingFade::State::NoPoseYet: return "no pose yet";
    case BuildingFade::State::Shown: return "shown";
    case BuildingFade::State::FadingOut: return "fading out";
    case BuildingFade::State::Hidden: return "hidden";
    case BuildingFade::State::FadingIn: return "fading in";
  }
  return "shown";
}

LiveTracking::LiveTracking(const LiveConfig& config, const camera::CameraCalibration& hmd,
                           const camera::StereoCalibration* stereo) {
  if (config.pose.kind != track::PoseConfig::Kind::Markers) {
    configured_ = track::open_pose_source(config.pose);
    return;
  }
  tracker_ = stereo ? track::open_stereo_marker_tracker(config.pose, *stereo) : track::open_marker_tracker(config.pose, &hmd);
  if (config.imu || config.fusion) fusion_ = std::make_unique<track::PoseFusion>(config.fusion.value_or(track::FusionSettings{}));
  if (config.imu) imu_ = track::open_imu(*config.imu);
}

LiveTracking::~LiveTracking() {
  if (imu_) imu_->close();
}

std::size_t LiveTracking::feed_imu(double until) {
  if (!imu_ || !fusion_) return 0;
  const std::lock_guard lock(imu_mutex_);
  return fusion_->add_imu_from(*imu_, until);
}

std::optional<track::ImuState> LiveTracking::imu_state() const {
  if (!imu_) return std::nullopt;
  const std::lock_guard lock(imu_mutex_);
  return imu_->state();
}

void LiveTracking::on_camera_frame(const cv::Mat& image, double timestamp, const cv::Mat& right) {
  if (!tracker_) return;
  try {
    const track::MarkerSolve solve = tracker_->stereo()
                                         ? tracker_->process(tracker_image(image), tracker_image(right), timestamp)
                                         : tracker_->process(tracker_image(image), timestamp);
    if (!tracker_->accepts(solve)) {
      ++solves_rejected_;
      return;
    }
    ++solves_accepted_;
    if (fusion_) {
      // The gyro up to the frame first, so that the camera pose lands inside the gyro's history.
      feed_imu(timestamp);
      fusion_->add_camera_pose(*solve.pose);
    }
  } catch (const std::exception& e) {
    ++tracker_errors_;
    const std::lock_guard lock(mutex_);
    last_tracker_error_ = e.what();
  }
}

std::optional<track::Pose> LiveTracking::pose_for_frame(double frame_timestamp, double display_delay) {
  std::optional<track::Pose> pose;
  std::optional<track::FusedPose> estimate;
  if (fusion_) {
    // Video see-through: the building is drawn over this very camera frame, so it takes the pose
    // at the frame's capture time (the IMU carries it between marker solves). Predicting to the
    // display time would make it slip against the background by the head's motion in the delay,
    // which is reported (display_delay) but not applied.
    feed_imu(frame_timestamp);
    estimate = fusion_->estimate(frame_timestamp);
    if (estimate->state == track::TrackingState::Tracking || estimate->state == track::TrackingState::Coasting) {
      pose = estimate->pose;
    }
  } else if (tracker_) {
    pose = tracker_->pose_at(frame_timestamp);
  } else {
    pose = configured_->pose_at(frame_timestamp);
  }
  const std::lock_guard lock(mutex_);
  if (pose) last_pose_ = pose;
  if (estimate) last_estimate_ = estimate;
  last_display_delay_ = display_delay;
  return pose;
}

nlohmann::json LiveTracking::report() const {
  nlohmann::json j;
  j["source"] = fusion_ ? fusion_->describe() + " of " + tracker_->describe() : tracker_ ? tracker_->describe() : configured_->describe();
  {
    const std::lock_guard lock(mutex_);
    j["last"] = last_pose_ ? pose_json(*last_pose_) : nlohmann::json(nullptr);
  }
  if (!tracker_) return j;

  nlohmann::json markers;
  markers["accepted"] = solves_accepted_.load();
  markers["rejected"] = solves_rejected_.load();
  markers["errors"] = tracker_errors_.load();
  {
    const std::lock_guard lock(mutex_);
    markers["last_error"] = last_tracker_error_;
  }
  if (const auto solve = tracker_->latest_solve()) {
    nlohmann::json latest;
    latest["tags_seen"] = solve->tags_used.size();
    latest["tags_used"] = solve->tags_used;
    latest["tags_rejected"] = solve->tags_rejected;
    latest["tags_unknown"] = solve->tags_unknown;
    latest["reprojection_error_px"] = solve->pose ? nlohmann::json(solve->rms_px) : nlohmann::json(nullptr);
    latest["ambiguity"] = solve->ambiguity;
    latest["accepted"] = tracker_->accepts(*solve);
    latest["flags"] = solve->describe_flags();
    latest["pose"] = solve->pose ? pose_json(*solve->pose) : nlohmann::json(nullptr);
    markers["latest"] = latest;
  } else {
    markers["latest"] = nullptr;
  }
  j["markers"] = markers;

  if (fusion_) {
    nlohmann::json tracking;
    std::optional<track::FusedPose> estimate;
    double display_delay = 0;
    {
      const std::lock_guard lock(mutex_);
      estimate = last_estimate_;
      display_delay = last_display_delay_;
    }
    tracking["state"] = estimate ? track::to_string(estimate->state) : track::to_string(track::TrackingState::Initializing);
    tracking["imu_link"] = estimate ? track::to_string(estimate->imu) : track::to_string(track::ImuLink::None);
    tracking["confidence"] = estimate ? estimate->confidence : 0.0;
    tracking["camera_age_s"] = estimate && std::isfinite(estimate->camera_age) ? nlohmann::json(estimate->camera_age) : nlohmann::json(nullptr);
    tracking["rotation_sigma_deg"] = estimate ? estimate->rotation_sigma * 180 / std::numbers::pi : 0.0;
    tracking["display_delay_s"] = display_delay;
    const track::FusionCounters counters = fusion_->counters();
    tracking["camera_poses"] = counters.camera_poses;
    tracking["late_camera_poses"] = counters.late_camera_poses;
    tracking["imu_samples"] = counters.imu_samples;
    j["tracking"] = tracking;
  }
  if (const auto state = imu_state()) j["imu"] = {{"source", imu_->describe()}, {"state", track::to_string(*state)}};
  return j;
}

void LiveTracking::add_flags(std::vector<std::string>& flags) const {
  if (!tracker_) return;
  const auto solve = tracker_->latest_solve();
  if (solve && !tracker_->accepts(*solve)) flags.push_back("markers_not_accepted");
  if (tracker_errors_ > 0) flags.push_back("tracker_errors");
  {
    const std::lock_guard lock(mutex_);
    if (last_estimate_ && last_estimate_->state == track::TrackingState::Lost) flags.push_back("tracking_lost");
  }
  if (imu_state() == track::ImuState::Gone) flags.push_back("imu_gone");
}

void LiveTracking::add_metrics(std::vector<Metric>& m) const {
  if (!tracker_) return;
  const char* solves_help = "Marker solves, accepted as the pose or refused (no tags, high error, ambiguous).";
  m.push_back({"skylit_marker_solves_total", solves_help, "counter", double(solves_accepted_.load()), "result=\"accepted\""});
  m.push_back({"skylit_marker_solves_total", solves_help, "counter", double(solves_rejected_.load()), "result=\"refused\""});
  m.push_back({"skylit_marker_solves_total", solves_help, "counter", double(tracker_errors_.load()), "result=\"error\""});
  const auto solve = tracker_->latest_solve();
  m.push_back({"skylit_marker_tags_seen", "Map tags the latest marker solve rests on.", "gauge",
               solve ? double(solve->tags_used.size()) : 0.0, ""});
  m.push_back({"skylit_marker_reprojection_error_pixels", "RMS reprojection error of the latest marker solve (+Inf without a pose).",
               "gauge", solve && solve->pose ? solve->rms_px : std::numeric_limits<double>::infinity(), ""});
  if (!fusion_) return;
  std::optional<track::FusedPose> estimate;
  {
    const std::lock_guard lock(mutex_);
    estimate = last_estimate_;
  }
  const track::TrackingState state = estimate ? estimate->state : track::TrackingState::Initializing;
  for (const auto s : {track::TrackingState::Initializing, track::TrackingState::Tracking, track::TrackingState::Coasting,
                       track::TrackingState::Lost}) {
    m.push_back({"skylit_tracking_state", "1 for the fused tracking state (initializing, tracking, coasting, lost).", "gauge",
                 s == state ? 1.0 : 0.0, std::string("state=\"") + track::to_string(s) + "\""});
  }
  m.push_back({"skylit_tracking_confidence", "The fusion's confidence in the pose, 0..1.", "gauge",
               estimate ? estimate->confidence : 0.0, ""});
  m.push_back({"skylit_tracking_camera_age_seconds", "Seconds since the last accepted camera pose (+Inf before the first).", "gauge",
               estimate ? finite_or_infinity(estimate->camera_age) : std::numeric_limits<double>::infinity(), ""});
  m.push_back({"skylit_imu_samples_total", "IMU samples fused.", "counter", double(fusion_->counters().imu_samples), ""});
}

}  // namespace skylit::live
