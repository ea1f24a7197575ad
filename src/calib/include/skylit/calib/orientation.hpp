#pragma once
// The sky camera's orientation R_site_from_camera: from pairs of directions to the sun (seen by
// the camera, and computed for the site from the frame's time), a rotation fit (Wahba's problem,
// solved by SVD) with outliers rejected; or from a level and a compass bearing when there is no
// sun to see.
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace skylit::calib {

using Vec3 = Eigen::Vector3d;

struct SunObservation {
  std::string name;                // the frame (messages, reports)
  Vec3 camera_direction{0, 0, 1};  // unit, camera frame (OpenCV: x right, y down, z forward)
  Vec3 site_direction{0, 0, 1};    // unit, site frame (x east, y north, z up): the solar position
};

// The rotation R minimising Σ w_k |s_k − R c_k|² (s: site, c: camera directions), by SVD of
// B = Σ w_k s_k c_kᵀ with det R = +1 enforced. Needs two non-parallel pairs (otherwise the
// rotation about their common direction is arbitrary). Empty weights: all 1.
Eigen::Matrix3d solve_wahba(std::span<const Vec3> site, std::span<const Vec3> camera, std::span<const double> weights = {});

struct OrientationOptions {
  double outlier_threshold_deg = 2.0;    // a frame whose residual exceeds this is an outlier
  double min_spread_deg = 5.0;           // the sun must move at least this far (InputError below)
  double recommended_spread_deg = 30.0;  // advice below: the rotation about the sun's path is weak
};

struct OrientationFit {
  Eigen::Matrix3d R_site_from_camera = Eigen::Matrix3d::Identity();
  std::vector<double> residual_deg;  // per observation: angle between s_k and R c_k
  std::vector<bool> inlier;          // per observation
  int inliers = 0;
  double rms_deg = 0;     // over the inliers
  double spread_deg = 0;  // largest angle between two inliers' sun directions
  std::vector<std::string> advice;
};

// The rotation from all pairs: every pair of observations at least min_spread_deg apart
// proposes a rotation, the one most observations agree with (within the threshold) wins, and the
// rotation is refitted on those. InputError saying what to do with fewer than 2 observations,
// with no two sun directions min_spread_deg apart, or when no 2 observations agree.
OrientationFit fit_orientation(std::span<const SunObservation> observations, const OrientationOptions& options = {});

// A camera looking at the zenith, level, its image x axis (towards the right edge) pointing at
// `bearing_deg` (clockwise from true north: 90 = east): R_site_from_camera. The image's down
// (y) axis then points at bearing − 90° (seen from below, the image is the sky mirrored).
Eigen::Matrix3d level_compass_rotation(double bearing_deg);

// Angle of the rotation a·bᵀ (degrees): how far apart two orientations are.
double rotation_difference_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// Angle between two directions (degrees).
double angle_deg(const Vec3& a, const Vec3& b);

// Where a camera with this orientation looks: the optical axis's angle from the zenith, and the
// bearing (clockwise from true north) of the image's x axis projected on the horizon (what
// --level-compass takes).
struct Pointing {
  double tilt_from_zenith_deg = 0;
  double image_x_bearing_deg = 0;
};
Pointing describe_pointing(const Eigen::Matrix3d& R_site_from_camera);

}  // namespace skylit::calib
