#pragma once
// A small site for the marker-survey tests: six 20 cm tags on the ground and on two walls, one
// (tag 0) lying at the site's origin, photographed by a 1280×720 camera from eight places on an
// arc south of them. The truth is known, so the map found from the photos can be checked.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "skylit/calib/marker_survey.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/track/pose.hpp"

namespace skylit::calib_test {

inline constexpr double kMarkerDeg = std::numbers::pi / 180.0;

// fx = 800 px: 77° across 1280 px, with mild barrel distortion.
inline camera::CameraCalibration survey_camera() {
  camera::CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 720;
  c.model = camera::LensModel::Pinhole;
  c.fx = 800;
  c.fy = 800;
  c.cx = 639.5;
  c.cy = 359.5;
  c.D = {-0.06, 0.02, 0.0004, -0.0002, 0.0};
  return c;
}

inline track::MarkerTag tag_at(int id, const Eigen::Vector3d& position, const Eigen::Matrix3d& R, double size = 0.20) {
  track::MarkerTag tag;
  tag.id = id;
  tag.size = size;
  tag.R_site_from_tag = Eigen::Quaterniond(R);
  tag.t_site_from_tag = position;
  return tag;
}

inline Eigen::Matrix3d yaw(double deg) { return Eigen::AngleAxisd(deg * kMarkerDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

// Facing south (−y): x east, y up.
inline Eigen::Matrix3d facing_south() {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  return R;
}

// Facing west (−x): x south, y up.
inline Eigen::Matrix3d facing_west() {
  Eigen::Matrix3d R;
  R << 0, 0, -1, -1, 0, 0, 0, 1, 0;
  return R;
}

// The origin (0) and a second tag on the ground, two on the north wall, one on the east wall, a
// third on the ground.
inline track::MarkerMap survey_site() {
  track::MarkerMap map;
  map.tags = {tag_at(0, {0, 0, 0}, Eigen::Matrix3d::Identity()), tag_at(1, {1.1, 0.7, 0}, yaw(30)),
              tag_at(2, {-0.8, 2.5, 0.9}, facing_south()),        tag_at(3, {0.6, 2.5, 1.3}, facing_south()),
              tag_at(4, {2.2, 1.6, 1.0}, facing_west()),          tag_at(5, {-1.0, 1.2, 0}, yaw(-20))};
  return map;
}

// Eight places on an arc south of the tags, 1.3–1.8 m up, looking at the middle of the site.
inline std::vector<track::Pose> survey_viewpoints() {
  std::vector<track::Pose> poses;
  const Eigen::Vector3d middle(0.3, 1.2, 0.5);
  for (int k = 0; k < 8; ++k) {
    const double bearing = (-60.0 + 120.0 * k / 7.0) * kMarkerDeg;  // from the south, positive towards the east
    const double radius = 3.0 + 0.25 * std::sin(1.7 * k);
    track::Pose pose;
    pose.t_site_from_camera = middle + Eigen::Vector3d(radius * std::sin(bearing), -radius * std::cos(bearing), 0.0);
    pose.t_site_from_camera.z() = 1.3 + 0.5 * ((k * 3) % 5) / 4.0;
    const Eigen::Vector3d target = middle + Eigen::Vector3d(0.1 * std::cos(k), 0.1 * std::sin(2.0 * k), 0.0);
    pose.R_site_from_camera = track::look_at(pose.t_site_from_camera, target) *
                              Eigen::Quaterniond(Eigen::AngleAxisd((k % 3 - 1) * 4.0 * kMarkerDeg, Eigen::Vector3d::UnitZ()));
    poses.push_back(pose);
  }
  return poses;
}

// The tags' corners projected through the lens, with Gaussian pixel noise: detections without
// rendering, for the tests of the solver's logic.
inline std::vector<track::TagDetection> project_tags(const track::MarkerMap& map, const camera::CameraCalibration& camera,
                                                     const track::Pose& pose, double noise_px, std::mt19937& random) {
  const camera::Lens lens(camera);
  std::normal_distribution<double> noise(0.0, noise_px);
  const Eigen::Matrix3d R_cs = pose.R_site_from_camera.toRotationMatrix().transpose();
  std::vector<track::TagDetection> out;
  for (const track::MarkerTag& tag : map.tags) {
    track::TagDetection d;
    d.id = tag.id;
    bool visible = true;
    const auto corners = track::tag_corners_in_site(tag);
    for (std::size_t k = 0; k < 4; ++k) {
      const Eigen::Vector3d in_camera = R_cs * (corners[k] - pose.t_site_from_camera);
      const std::optional<Eigen::Vector2d> pixel = in_camera.z() > 0.1 ? lens.project(in_camera) : std::nullopt;
      if (!pixel || pixel->x() < 0 || pixel->y() < 0 || pixel->x() > camera.image_width - 1 ||
          pixel->y() > camera.image_height - 1) {
        visible = false;
        break;
      }
      d.corners[k] = *pixel + Eigen::Vector2d(noise(random), noise(random));
    }
    // Seen from the front only.
    const Eigen::Vector3d normal = tag.R_site_from_tag * Eigen::Vector3d::UnitZ();
    if (visible && normal.dot(pose.t_site_from_camera - tag.t_site_from_tag) > 0) out.push_back(d);
  }
  return out;
}

inline double position_error_m(const track::MarkerTag& a, const track::MarkerTag& b) {
  return (a.t_site_from_tag - b.t_site_from_tag).norm();
}
inline double rotation_error_deg(const track::MarkerTag& a, const track::MarkerTag& b) {
  return a.R_site_from_tag.angularDistance(b.R_site_from_tag) / kMarkerDeg;
}

}  // namespace skylit::calib_test
