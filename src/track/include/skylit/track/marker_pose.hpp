#pragma once
// The camera's pose from the tags of a marker map seen in one frame.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_options.hpp"
#include "skylit/track/pose.hpp"
#include "skylit/track/tag_detector.hpp"

namespace skylit::track {

// Which camera of a stereo camera saw a tag (a single camera's solve says Left throughout).
enum class CameraSide { Left, Right };

// Errors are in pixels of the (distorted) frame of the camera that saw the tag.
struct TagResidual {
  int id = 0;
  double rms_px = 0;   // RMS reprojection error of the tag's four corners under the pose
  double edge_px = 0;  // the tag's mean edge length in the frame
  CameraSide camera = CameraSide::Left;
};

struct MarkerSolve {
  std::optional<Pose> pose;          // the camera in the site (timestamp 0; the caller stamps it)
  double rms_px = 0;                 // over the corners of tags_used
  // The best solution that differs from `pose` by more than MarkerPoseOptions::distinct_deg (for
  // a single tag, its other IPPE solution), when the data admit one.
  std::optional<Pose> alternative;
  double alternative_rms_px = 0;
  double ambiguity = 0;              // rms_px / alternative_rms_px: 0..1, 0 without an alternative
  std::vector<int> tags_used;        // map tags the pose rests on
  std::vector<int> tags_rejected;    // map tags dropped as outliers
  std::vector<int> tags_unknown;     // detected ids that the map does not hold
  // tags_used then tags_rejected, under `pose`; a stereo solve has one per camera that saw the tag.
  std::vector<TagResidual> residuals;

  // Flags: no map tag seen (no pose); one tag only, small in the frame; two solutions fit almost
  // equally; the pose reprojects worse than MarkerPoseOptions::max_error_px.
  bool no_tags = false;
  bool single_distant_tag = false;
  bool ambiguous = false;
  bool high_error = false;

  // "no tags", "ambiguous, single distant tag", "ok".
  std::string describe_flags() const;
};

// The corners are undistorted through the camera's calibrated lens (pinhole or fisheye), each
// tag gives its two planar solutions (IPPE), every solution is refined by Levenberg–Marquardt
// over every corner of every tag, and the best one is kept. A tag whose corners then reproject
// badly is dropped (leave-one-out: the tag whose removal leaves the others agreeing best) and the
// pose solved again.
//
// std::invalid_argument when the options are out of range.
MarkerSolve solve_marker_pose(const MarkerMap& map, const camera::Lens& lens, std::span<const TagDetection> detections,
                              const MarkerPoseOptions& options = {});

}  // namespace skylit::track
