#pragma once
// The marker tracker as a pose source: frames of the HMD camera (or both frames of a stereo
// camera) go in (process), the pose of the latest frame whose solve was accepted comes out.
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "skylit/camera/lens.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_options.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/track/marker_pose_stereo.hpp"
#include "skylit/track/pose.hpp"
#include "skylit/track/tag_detector.hpp"

namespace cv {
class Mat;
}

namespace skylit::track {

// A solve is accepted when it has a pose and is not high_error, nor (unless the options accept
// them) ambiguous or from a single distant tag. Every solve, accepted or not, is kept for status.
// process() runs on the camera's thread; pose_at, describe and latest_solve may be called from
// any thread.
class MarkerTracker final : public PoseSource {
 public:
  // The detector's family is the map's (options.detector.family is overridden). std::invalid_argument
  // for options out of range; InputError (naming the calibration file) for a calibration that
  // does not validate.
  MarkerTracker(MarkerMap map, const camera::CameraCalibration& camera, const MarkerTrackerOptions& options = {});
  // A stereo camera's tracker: its pose is the LEFT camera's, solved from the cameras
  // options.stereo_cameras names (solve_marker_pose_stereo for both). InputError naming the
  // stereo calibration's file for one that does not validate.
  MarkerTracker(MarkerMap map, const camera::StereoCalibration& stereo, const MarkerTrackerOptions& options = {});

  // Detects the map's tags in `frame` (8-bit grey or BGR, the calibration's size: InputError
  // naming the calibration otherwise), solves the pose and keeps it when accepted.
  // std::logic_error on a stereo camera's tracker (it takes both frames).
  MarkerSolve process(const cv::Mat& frame, double timestamp);
  // A stereo camera's pair of frames, taken at `timestamp`: tags are detected in the frames of the
  // cameras in use (each of its calibration's size, else InputError naming the stereo calibration
  // and the camera), then solved. std::logic_error on a single camera's tracker.
  MarkerSolve process(const cv::Mat& left_frame, const cv::Mat& right_frame, double timestamp);

  // The latest accepted pose, stamped `timestamp`, when its frame is at most max_age away.
  std::optional<Pose> pose_at(double timestamp) override;
  std::string describe() const override;
  // Whether a solve is kept as the pose, by the rule above and these options.
  bool accepts(const MarkerSolve& solve) const;
  // The latest solve (accepted or not), stamped with its frame's time.
  std::optional<MarkerSolve> latest_solve() const;
  const MarkerMap& map() const { return map_; }
  bool stereo() const { return stereo_.has_value(); }

 private:
  // The right camera of a stereo camera, and where it is relative to the left (lens_).
  struct RightCamera {
    camera::Lens lens;
    StereoExtrinsics extrinsics;
    std::filesystem::path file;  // the stereo calibration's (messages)
  };
  MarkerSolve keep(MarkerSolve solve, double timestamp);

  MarkerMap map_;
  camera::Lens lens_;  // the camera's, or a stereo camera's left one
  std::optional<RightCamera> stereo_;
  MarkerTrackerOptions options_;
  TagDetector detector_;
  mutable std::mutex mutex_;  // guards the three below
  std::optional<Pose> accepted_;
  std::optional<MarkerSolve> latest_;
  std::size_t frames_ = 0;
};

// The tracker a `pose: {kind: markers}` config describes: its map, and its calibration file or,
// when the config names none, `camera` (the HMD camera's calibration of the live config).
// std::invalid_argument when the config is not of kind markers or there is no calibration.
std::unique_ptr<MarkerTracker> open_marker_tracker(const PoseConfig& config,
                                                   const camera::CameraCalibration* camera = nullptr);
// The tracker of a stereo camera: its map, and `stereo` (the live config's camera.stereo), or
// the stereo calibration file the config's `calibration:` names. std::invalid_argument when the
// config is not of kind markers.
std::unique_ptr<MarkerTracker> open_stereo_marker_tracker(const PoseConfig& config, const camera::StereoCalibration& stereo);

}  // namespace skylit::track
