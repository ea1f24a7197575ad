#pragma once
// The left camera's pose from the tags a stereo camera (a camera per eye) sees in one pair of
// frames: both cameras' corners in one solve through the fixed extrinsics.
#include <span>

#include <Eigen/Core>

#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_options.hpp"
#include "skylit/track/marker_pose.hpp"
#include "skylit/track/tag_detector.hpp"

namespace skylit::track {

// The right camera's pose relative to the left one: x_right = R_right_from_left · x_left +
// t_right_from_left (camera::StereoCalibration's convention).
struct StereoExtrinsics {
  Eigen::Matrix3d R_right_from_left = Eigen::Matrix3d::Identity();
  Vec3 t_right_from_left = Vec3::Zero();  // metres
};

// The left camera's pose from the right camera's (the tracked pose is always the left camera's),
// and back.
Pose left_camera_pose(const Pose& right_camera, const StereoExtrinsics& extrinsics);
Pose right_camera_pose(const Pose& left_camera, const StereoExtrinsics& extrinsics);
// The right camera's own solve (solve_marker_pose on its lens and detections) as the left
// camera's: poses moved, residuals marked CameraSide::Right.
MarkerSolve as_left_camera(MarkerSolve right_camera_solve, const StereoExtrinsics& extrinsics);

// Each camera is first solved alone (solve_marker_pose: its IPPE starts, its own outlier tags).
// The starts of the joint solve are both cameras' poses and their alternatives, the right
// camera's moved to the left one; they are ranked by their error over every corner of both
// frames and refined in that order by Levenberg–Marquardt (Ceres) over all of them, the right
// camera's corners projected through the fixed extrinsics; the best is the pose, the best that
// differs by more than distinct_deg the alternative (the ambiguity is over both frames). Then,
// while some tag's view reprojects worse than outlier_px and at least three tags are in use, the
// view (one tag in one camera) whose removal leaves the rest agreeing best is dropped.
//
// The MarkerSolve: `pose` and `alternative` are the LEFT camera's; rms_px is over the corners of
// every view used; tags_used, tags_rejected and tags_unknown list map ids over both cameras
// (sorted, each once; a tag used in one camera and rejected in the other is in both lists);
// `residuals` has one entry per view, its `camera` saying whose frame (used views first).
// single_distant_tag: the pose rests on one tag, under distant_tag_px in every view of it.
// With tags in one camera only, the result is that camera's own solve (moved to the left camera
// when it is the right one's).
//
// std::invalid_argument when the options are out of range or R_right_from_left is not a rotation.
MarkerSolve solve_marker_pose_stereo(const MarkerMap& map, const camera::Lens& left_lens, const camera::Lens& right_lens,
                                     const Eigen::Matrix3d& R_right_from_left, const Vec3& t_right_from_left,
                                     std::span<const TagDetection> left_detections,
                                     std::span<const TagDetection> right_detections,
                                     const MarkerPoseOptions& options = {});

}  // namespace skylit::track
