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

MarkerSolve MarkerTracker::process(const cv::Mat& frame, double timestamp) {
  const camera::CameraCalibration& c = lens_.calibration();
  if (frame.cols != c.image_width || frame.rows != c.image_height) {
    throw InputError(input_message(c.file, -1, -1, "image_width",
                                   "the camera's frames are " + std::to_string(frame.cols) + "×" + std::to_string(frame.rows) +
                                       " but the calibration is for " + std::to_string(c.image_width) + "×" +
                                       std::to_string(c.image_height),
                                   "calibrate the camera at the resolution it streams (skylit-calib camera), or set "
                                   "the camera to the calibrated resolution"));
  }
  const std::vector<TagDetection> detections = detector_.detect(frame);
  MarkerSolve solve = solve_marker_pose(map_, lens_, detections, options_.pose);
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
