#pragma once
// Where a camera is: one interface for a fixed pose from the config, a recorded pose track
// (CSV) and the marker tracker (marker_tracker.hpp).
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "skylit/track/marker_options.hpp"

namespace YAML {
class Node;
}

namespace skylit::track {

using Vec3 = Eigen::Vector3d;

// Frames: the site frame is x east, y north, z up, metres; the camera frame is OpenCV's (x right,
// y down, z forward). A camera point p maps to the site as R_site_from_camera · p +
// t_site_from_camera, so t is the camera's position.
struct Pose {
  double timestamp = 0;  // seconds, on the clock of the frames the pose belongs to
  Eigen::Quaterniond R_site_from_camera = Eigen::Quaterniond::Identity();  // unit
  Vec3 t_site_from_camera = Vec3::Zero();                                   // metres
};

class PoseSource {
 public:
  virtual ~PoseSource() = default;
  // The pose at `timestamp` (stamped with it), or nullopt when the source has none then (a
  // tracker that lost its markers).
  virtual std::optional<Pose> pose_at(double timestamp) = 0;
  // "fixed pose at (0, 0, 1.6)", "pose track head.csv (1200 poses)": for messages and status.
  virtual std::string describe() const = 0;
};

// The camera's rotation when it stands at `position` and looks at `target`, the image's up
// (−y) towards `up` as far as it can. std::invalid_argument when target = position or the view
// is parallel to `up` (then give another `up`).
Eigen::Quaterniond look_at(const Vec3& position, const Vec3& target, const Vec3& up = Vec3::UnitZ());

class FixedPose final : public PoseSource {
 public:
  explicit FixedPose(const Pose& pose);
  std::optional<Pose> pose_at(double timestamp) override;
  std::string describe() const override;

 private:
  Pose pose_;
};

// Poses recorded at times; in between, position linear and rotation slerp; before the first and
// after the last, the end pose (clamped).
class PoseTrack final : public PoseSource {
 public:
  // Samples with strictly increasing timestamps and unit quaternions (std::invalid_argument
  // otherwise); at least one.
  PoseTrack(std::vector<Pose> samples, std::string name);
  // A CSV with the header line `timestamp,x,y,z,qw,qx,qy,qz` (seconds, metres, the quaternion
  // R_site_from_camera). InputError naming the file, line and column of a malformed line, of a
  // quaternion that is not unit length (within 1e-3; it is normalised) or of a timestamp that
  // does not increase.
  static PoseTrack load(const std::filesystem::path& csv);

  std::optional<Pose> pose_at(double timestamp) override;
  std::string describe() const override;
  const std::vector<Pose>& samples() const { return samples_; }

 private:
  std::vector<Pose> samples_;
  std::string name_;
};

// A `pose:` node of a config file:
//
//   pose:
//     kind: fixed
//     position: [0, 0, 1.6]          # metres, site frame
//     orientation: [1, 0, 0, 0]      # qw, qx, qy, qz of R_site_from_camera
//     # or, instead of orientation:
//     look_at: [10, 0, 1.6]          # a site point the camera looks at
//     up: [0, 0, 1]                  # optional, default up
//
//   pose:
//     kind: track
//     csv: head_track.csv            # relative to the config file's folder
//
//   pose:
//     kind: markers                  # AprilTags on the site (docs/tracking.md)
//     map: site_tags.yaml            # the marker map, relative to the config file's folder
//     calibration: hmd_camera.yaml   # optional: the camera's; default the HMD camera's
//     decimation: 2                  # optional knobs (MarkerTrackerOptions), e.g. blur, threads
//     cameras: both                  # a stereo camera's: left, right or both (the default)
struct PoseConfig {
  enum class Kind { Fixed, Track, Markers };
  Kind kind = Kind::Fixed;
  Pose fixed;                  // Kind::Fixed
  std::filesystem::path csv;   // Kind::Track
  std::filesystem::path marker_map;          // Kind::Markers
  std::filesystem::path marker_calibration;  // Kind::Markers; empty: the HMD camera's
  MarkerTrackerOptions markers;              // Kind::Markers
  std::filesystem::path file;                // the config it was read from (messages)
};

// InputError naming the file, line, column and field for anything missing, unknown or wrong.
// `root`: the folder its paths must lie in (the including config's root); empty, the file's folder.
PoseConfig parse_pose_config(const YAML::Node& node, const std::filesystem::path& file,
                             const std::filesystem::path& root = {});
// A YAML file whose top level has a `pose:` node.
PoseConfig load_pose_config(const std::filesystem::path& file);
// The source of a fixed or track config. Kind::Markers needs the camera's frames: use
// open_marker_tracker (marker_tracker.hpp) and feed it, as skylit-live does; here it is an
// InputError naming the config's pose.kind (for tools that take no camera frames).
std::unique_ptr<PoseSource> open_pose_source(const PoseConfig& config);

}  // namespace skylit::track
