#pragma once
// Where the HMD camera is, for the service: the config's fixed pose or pose track as they are, or
// the marker tracker fed with every HMD camera frame, its poses used as they are or fused with
// the IMU's gyro (track::PoseFusion) and predicted to the time the frame is shown.
//
// Threads: on_camera_frame belongs to the camera thread, pose_for_frame to the render thread;
// report and metrics may be called from any thread (the status server's).
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "skylit/live/live_config.hpp"
#include "skylit/live/status_server.hpp"
#include "skylit/camera/calibration.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/track/fusion.hpp"
#include "skylit/track/imu.hpp"
#include "skylit/track/marker_tracker.hpp"
#include "skylit/track/pose.hpp"

namespace skylit::live {

class LiveTracking {
 public:
  // Opens the pose source the config names; with pose.kind markers the tracker (its map, its
  // calibration or `hmd`), and the IMU when the config has one (InputError when it is absent at
  // start: a HID device not plugged in, a recording that is not there). With `stereo` (the
  // config's camera.stereo) the tracker sees both cameras (track::open_stereo_marker_tracker).
  LiveTracking(const LiveConfig& config, const camera::CameraCalibration& hmd,
               const camera::StereoCalibration* stereo = nullptr);
  ~LiveTracking();
  LiveTracking(const LiveTracking&) = delete;
  LiveTracking& operator=(const LiveTracking&) = delete;

  bool uses_markers() const { return tracker_ != nullptr; }

  // Camera thread, for each frame before it is handed to the renderer: detects the tags and
  // solves the pose (markers), and gives an accepted pose to the fusion. A frame the tracker
  // refuses (a size the calibration is not for) is counted and reported, never thrown: the frame
  // is still shown.
  // With a stereo camera, `image` is the left camera's and `right` the right camera's.
  void on_camera_frame(const cv::Mat& image, double timestamp, const cv::Mat& right = {});

  // Render thread: the pose to draw the frame stamped `frame_timestamp` from, at its capture
  // time (video see-through). `display_delay` (seconds), how long after its capture the frame
  // will be on the display, is kept for status. Nullopt when there is none (tracking lost, no
  // accepted solve recently).
  std::optional<track::Pose> pose_for_frame(double frame_timestamp, double display_delay);

  // The "pose" object of /status (without the service's own counters), and the flags it raises.
  nlohmann::json report() const;
  void add_flags(std::vector<std::string>& flags) const;
  void add_metrics(std::vector<Metric>& metrics) const;

 private:
  std::size_t feed_imu(double until);
  std::optional<track::ImuState> imu_state() const;

  std::unique_ptr<track::PoseSource> configured_;      // pose.kind fixed or track
  std::unique_ptr<track::MarkerTracker> tracker_;      // pose.kind markers
  std::unique_ptr<track::PoseFusion> fusion_;          // markers with imu or fusion
  std::unique_ptr<track::ImuSource> imu_;
  mutable std::mutex imu_mutex_;  // the IMU is read by the camera and render threads, its state by the status

  std::atomic<std::int64_t> solves_accepted_{0}, solves_rejected_{0}, tracker_errors_{0};
  mutable std::mutex mutex_;  // guards the members below
  std::string last_tracker_error_;
  std::optional<track::Pose> last_pose_;          // the last pose handed to the renderer
  std::optional<track::FusedPose> last_estimate_;  // the fusion's estimate for it
  double last_display_delay_ = 0;
};

// The building's opacity from frame to frame (tracking.fade_s, docs/live.md "Tracking lost"): a
// clear tracking-lost state in which the building fades instead of jumping. While frames have a
// pose it is shown at full opacity; when the pose goes missing it fades out, still at the last
// pose, by 1/fade_s per second of frame time; when a pose returns after a loss the building is
// drawn at the new pose from opacity 0 and fades in, so it never jumps to a new pose at full
// opacity. The first pose of a run shows it at once, like the first sky does.
//
// Time is the frames' own timestamps: a recording fades over the same frames however fast it
// plays. Threads: next() belongs to the render thread; opacity() and state() may be read from any.
class BuildingFade {
 public:
  enum class State { NoPoseYet, Shown, FadingOut, Hidden, FadingIn };

  // fade_s ≥ 0; 0: hidden at once when the pose is lost, shown at once when it returns.
  explicit BuildingFade(double fade_s) : fade_s_(fade_s) {}

  // The opacity to draw the frame stamped `timestamp` with, `has_pose` whether it has its own pose.
  double next(bool has_pose, double timestamp);

  double opacity() const { return opacity_.load(); }
  State state() const { return state_.load(); }
  double fade_s() const { return fade_s_; }

 private:
  const double fade_s_;
  std::optional<double> last_timestamp_;
  bool had_pose_ = false;
  std::atomic<double> opacity_{0.0};
  std::atomic<State> state_{State::NoPoseYet};
};

std::string to_string(BuildingFade::State state);  // "no pose yet", "shown", "fading out", "hidden", "fading in"

// An 8-bit grey or BGR image for the tag detector: 8-bit frames as they are, 16-bit ones scaled,
// float (linear) ones clipped to [0, 1] and scaled.
cv::Mat tracker_image(const cv::Mat& image);

}  // namespace skylit::live
