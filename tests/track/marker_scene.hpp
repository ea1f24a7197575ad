#pragma once
// Scenes for the marker tests: a 1280×720 HMD camera with a little distortion, tags of 20 cm on a
// wall 3 m north of the camera, and the errors of a pose against the truth.
#include <numbers>
#include <vector>

#include <Eigen/Geometry>

#include "skylit/camera/calibration.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/pose.hpp"

namespace marker_scene {

using skylit::track::MarkerMap;
using skylit::track::MarkerTag;
using skylit::track::Pose;
using skylit::track::Vec3;

// fx = 1000 px: 65° across the 1280 px width; mild barrel distortion with a little tangential.
inline skylit::camera::CameraCalibration hmd_camera() {
  skylit::camera::CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = skylit::camera::LensModel::Pinhole;
  c.fx = 1000;
  c.fy = 1000;
  c.cx = 639.5;
  c.cy = 359.5;
  c.D = {-0.08, 0.03, 0.0005, -0.0003, 0.0};
  return c;
}

// A tag on the wall y = wall_y, facing south (towards the camera): its x east, y up, z south.
inline MarkerTag wall_tag(int id, double x, double z, double size = 0.20, double wall_y = 3.0) {
  Eigen::Matrix3d R;
  R.col(0) = Vec3(1, 0, 0);
  R.col(1) = Vec3(0, 0, 1);
  R.col(2) = Vec3(0, -1, 0);
  MarkerTag tag;
  tag.id = id;
  tag.size = size;
  tag.R_site_from_tag = Eigen::Quaterniond(R);
  tag.t_site_from_tag = Vec3(x, wall_y, z);
  return tag;
}

// Four 20 cm tags on the wall 3 m north, 1.0 m × 0.6 m apart, around eye height.
inline MarkerMap wall_of_four() {
  MarkerMap map;
  map.family = "tag36h11";
  map.tags = {wall_tag(0, -0.5, 1.9), wall_tag(1, 0.5, 1.9), wall_tag(2, -0.5, 1.3), wall_tag(3, 0.5, 1.3)};
  return map;
}

// A head at `position` looking at `target`, rolled by `roll_deg` about its view.
inline Pose head(const Vec3& position, const Vec3& target, double roll_deg = 0) {
  Pose pose;
  pose.t_site_from_camera = position;
  pose.R_site_from_camera = skylit::track::look_at(position, target) *
                            Eigen::Quaterniond(Eigen::AngleAxisd(roll_deg * std::numbers::pi / 180, Vec3::UnitZ()));
  return pose;
}

// Heads about 3 m from the wall, looking at its tags from a little aside, rolled a little.
inline std::vector<Pose> heads_at_three_metres() {
  return {head(Vec3(0.1, 0.0, 1.6), Vec3(0.0, 3.0, 1.6), 2),
          head(Vec3(-0.6, 0.2, 1.7), Vec3(0.1, 3.0, 1.5), -4),
          head(Vec3(0.7, -0.1, 1.5), Vec3(-0.1, 3.0, 1.7), 6)};
}

inline double position_error(const Pose& a, const Pose& b) { return (a.t_site_from_camera - b.t_site_from_camera).norm(); }
inline double rotation_error_deg(const Pose& a, const Pose& b) {
  return a.R_site_from_camera.angularDistance(b.R_site_from_camera) * 180 / std::numbers::pi;
}

}  // namespace marker_scene
