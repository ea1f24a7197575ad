// The marker tracker behind the PoseSource interface.
#include "skylit/track/marker_tracker.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <opencv2/core/mat.hpp>

#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::track {
namespace {

TagDetectorOptions with_family(TagDetectorOptions options, const std::string& family) {
  options.family = family;
  return options;
}

// InputError naming `file` and `field` when a frame is not of the calibrated size.
void check_frame_size(const cv::Mat& frame, const camera::CameraCalibration& c, const std::filesystem::path& file,
                      const std::string& field, const std::string& which) {
  if (frame.cols == c.image_width && frame.rows == c.image_height) return;
  throw InputError(input_message(file, -1, -1, field,
                                 which + " frames are " + std::to_string(frame.cols) + "×" + std::to_string(frame.rows) +
                                     " but the calibration is for " + std::to_string(c.image_width) + "×" +
                                     std::to_string(c.image_height),
                                 "calibrate the camera at the resolution it streams (skylit-calib camera), or set "
                                 "the camera to the calibrated resolution"));
}

const camera::StereoCalibration& validated(const camera::StereoCalibration& stereo) {
  camera::validate(stereo);
  return stereo;
}

bool accepted(const MarkerSolve& solve, const MarkerTrackerOptions& options) {
  return solve.pose && !solve.high_error && (options.accept_ambiguous || !solve.ambiguous) &&
         (options.accept_single_distant || !solve.single_distant_tag);
}

}  // namespace

MarkerTracker::MarkerTracker(MarkerMap map, const camera::CameraCalibration& camera, const MarkerTrackerOptions& options)
    : map_(std::move(map)),
      lens_(camera),
      options_(options),
      detector_(with_family(options.detector, map_.family)) {
  options_.detector.family = map_.family;
  if (!(options_.max_age >= 0) || !std::isfinite(options_.max_age)) {
    throw std::invalid_argument("MarkerTracker: max_age must be a finite number ≥ 0");
  }
  // Checked now rather than at the first frame.
  (void)solve_marker_pose(map_, lens_, {}, options_.pose);
}

MarkerTracker::MarkerTracker(MarkerMap map, const camera::StereoCalibration& stereo, const MarkerTrackerOptions& options)
    : MarkerTracker(std::move(map), validated(stereo).left, options) {
  stereo_ = RightCamera{camera::Lens(stereo.right), {stereo.R_right_from_left, stereo.t_right_from_left}, stereo.file};
  (void)solve_marker_pose_stereo(map_, lens_, stereo_->lens, stereo_->extrinsics.R_right_from_left,
                                 stereo_->extrinsics.t_right_from_left, {}, {}, options_.pose);
}

MarkerSolve MarkerTracker::process(const cv::Mat& frame, double timestamp) {
  if (stereo_) throw std::logic_error("MarkerTracker: a stereo camera's tracker takes both frames (process(left, right, t))");
  const camera::CameraCalibration& c = lens_.calibration();
  check_frame_size(frame, c, c.file, "image_width", "the camera's");
  return keep(solve_marker_pose(map_, lens_, detector_.detect(frame), options_.pose), timestamp);
}

MarkerSolve MarkerTracker::process(const cv::Mat& left_frame, const cv::Mat& right_frame, double timestamp) {
  if (!stereo_) throw std::logic_error("MarkerTracker: a single camera's tracker takes one frame (process(frame, t))");
  check_frame_size(left_frame, lens_.calibration(), stereo_->file, "left.image_width", "the left camera's");
  check_frame_size(right_frame, stereo_->lens.calibration(), stereo_->file, "right.image_width", "the right camera's");
  const StereoExtrinsics& e = stereo_->extrinsics;
  switch (options_.stereo_cameras) {
    case StereoCameras::Left:
      return keep(solve_marker_pose(map_, lens_, detector_.detect(left_frame), options_.pose), timestamp);
    case StereoCameras::Right:
      return keep(as_left_camera(solve_marker_pose(map_, stereo_->lens, detector_.detect(right_frame), options_.pose), e),
                  timestamp);
    case StereoCameras::Both:
      break;
  }
  // One detector for both frames: process() runs on one thread, and the two detections in turn
  // cost what two trackers would.
  const std::vector<TagDetection> left = detector_.detect(left_frame);
  const std::vector<TagDetection> right = detector_.detect(right_frame);
  return keep(solve_marker_pose_stereo(map_, lens_, stereo_->lens, e.R_right_from_left, e.t_right_from_left, left, right,
                                       options_.pose),
              timestamp);
}

MarkerSolve MarkerTracker::keep(MarkerSolve solve, double timestamp) {
  if (solve.pose) solve.pose->timestamp = timestamp;
  if (solve.alternative) solve.alternative->timestamp = timestamp;
  const std::lock_guard lock(mutex_);
  ++frames_;
  if (accepts(solve)) accepted_ = solve.pose;
  latest_ = solve;
  return solve;
}

std::optional<Pose> MarkerTracker::pose_at(double timestamp) {
  const std::lock_guard lock(mutex_);
  if (!accepted_ || std::abs(timestamp - accepted_->timestamp) > options_.max_age) return std::nullopt;
  Pose pose = *accepted_;
  pose.timestamp = timestamp;
  return pose;
}

std::string MarkerTracker::describe() const {
  std::string text = "marker tracker (" + map_.family + ", " + std::to_string(map_.tags.size()) + " tags";
  if (!map_.file.empty()) text += " from " + map_.file.filename().string();
  if (stereo_) {
    text += options_.stereo_cameras == StereoCameras::Both ? "; stereo camera, both cameras"
                                                           : std::string("; stereo camera, the ") +
                                                                 to_string(options_.stereo_cameras) + " camera only";
  }
  text += ")";
  const std::lock_guard lock(mutex_);
  if (latest_) {
    char figures[96];
    std::snprintf(figures, sizeof figures, ": %zu frames, the last %zu tags, %.2f px RMS, ", frames_,
                  latest_->tags_used.size(), latest_->rms_px);
    text += figures + latest_->describe_flags();
  } else {
    text += ": no frame yet";
  }
  return text;
}

bool MarkerTracker::accepts(const MarkerSolve& solve) const { return accepted(solve, options_); }

std::optional<MarkerSolve> MarkerTracker::latest_solve() const {
  const std::lock_guard lock(mutex_);
  return latest_;
}

const char* to_string(StereoCameras cameras) {
  switch (cameras) {
    case StereoCameras::Left:
      return "left";
    case StereoCameras::Right:
      return "right";
    case StereoCameras::Both:
      return "both";
  }
  return "both";
}

std::unique_ptr<MarkerTracker> open_stereo_marker_tracker(const PoseConfig& config, const camera::StereoCalibration& stereo) {
  if (config.kind != PoseConfig::Kind::Markers) {
    throw std::invalid_argument("open_stereo_marker_tracker: the pose config is not of kind markers");
  }
  MarkerMap map = load_marker_map(config.marker_map);
  if (!config.marker_calibration.empty()) {
    return std::make_unique<MarkerTracker>(std::move(map), camera::load_stereo_calibration(config.marker_calibration),
                                           config.markers);
  }
  return std::make_unique<MarkerTracker>(std::move(map), stereo, config.markers);
}

std::unique_ptr<MarkerTracker> open_marker_tracker(const PoseConfig& config, const camera::CameraCalibration* camera) {
  if (config.kind != PoseConfig::Kind::Markers) throw std::invalid_argument("open_marker_tracker: the pose config is not of kind markers");
  MarkerMap map = load_marker_map(config.marker_map);
  if (!config.marker_calibration.empty()) {
    return std::make_unique<MarkerTracker>(std::move(map), camera::load_calibration(config.marker_calibration), config.markers);
  }
  if (camera == nullptr) throw std::invalid_argument("open_marker_tracker: no camera calibration in the config nor given");
  return std::make_unique<MarkerTracker>(std::move(map), *camera, config.markers);
}

}  // namespace skylit::track
