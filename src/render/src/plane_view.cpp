// Which shadowing planes a camera view can see (plane_view.hpp).
#include "skylit/render/plane_view.hpp"
#include "skylit/camera/lens.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace skylit::render {

bool plane_in_view(const geom::Plane& plane, const CameraPose& pose, const PinholeCamera& view,
                   const PlaneViewOptions& options) {
  // The corners of the plane's box in the camera frame.
  const Eigen::Matrix3d camera_from_site = pose.R_site_from_camera.transpose();
  const Eigen::Vector3d offset = options.thickness > 0.0 ? Eigen::Vector3d(options.thickness * plane.normal())
                                                         : Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> corners;
  for (const double s : {0.0, 1.0}) {
    for (const double t : {0.0, 1.0}) {
      const Eigen::Vector3d corner = plane.origin + s * plane.u + t * plane.v;
      corners.push_back(camera_from_site * (corner + offset - pose.t_site_from_camera));
      if (options.thickness > 0.0) corners.push_back(camera_from_site * (corner - offset - pose.t_site_from_camera));
    }
  }
  // The box clipped at z = near is the hull of its corners in front and of the points where the
  // segments between a corner in front and one behind cross z = near (every pair, not only the
  // edges: points inside the hull do not change its projected bounds).
  const double near = std::max(options.near, 1e-9);
  std::vector<Eigen::Vector3d> kept;
  for (std::size_t a = 0; a < corners.size(); ++a) {
    if (!corners[a].allFinite()) return true;  // nothing can be said: in view
    if (corners[a].z() >= near) kept.push_back(corners[a]);
    for (std::size_t b = 0; b < corners.size(); ++b) {
      if (corners[a].z() >= near && corners[b].z() < near) {
        const double f = (corners[a].z() - near) / (corners[a].z() - corners[b].z());
        kept.push_back(corners[a] + f * (corners[b] - corners[a]));
      }
    }
  }
  if (kept.empty()) return false;  // wholly behind the camera
  double low_x = std::numeric_limits<double>::infinity(), high_x = -low_x;
  double low_y = low_x, high_y = -low_x;
  for (const Eigen::Vector3d& point : kept) {
    const double x = view.fx * point.x() / std::max(point.z(), near) + view.cx;
    const double y = view.fy * point.y() / std::max(point.z(), near) + view.cy;
    low_x = std::min(low_x, x);
    high_x = std::max(high_x, x);
    low_y = std::min(low_y, y);
    high_y = std::max(high_y, y);
  }
  const double margin = std::max(options.margin_px, 0.0);
  return high_x >= -0.5 - margin && low_x <= view.width - 0.5 + margin && high_y >= -0.5 - margin &&
         low_y <= view.height - 0.5 + margin;
}

PinholeCamera undistorted_view(const camera::CameraCalibration& calibration, double max_angle_deg) {
  PinholeCamera view;
  view.fx = calibration.fx;
  view.fy = calibration.fy;
  const bool distortion = std::any_of(calibration.D.begin(), calibration.D.end(), [](double d) { return d != 0.0; });
  if (calibration.model == camera::LensModel::Pinhole && !distortion) {
    view.width = calibration.image_width;
    view.height = calibration.image_height;
    view.cx = calibration.cx;
    view.cy = calibration.cy;
    return view;
  }
  const camera::Lens lens(calibration);
  const double max_angle = std::clamp(max_angle_deg, 1.0, 89.0) * std::numbers::pi / 180.0;
  const double max_tan = std::tan(max_angle);
  double low_x = std::numeric_limits<double>::infinity(), high_x = -low_x;
  double low_y = low_x, high_y = -low_x;
  auto include = [&](double x, double y) {
    low_x = std::min(low_x, x);
    high_x = std::max(high_x, x);
    low_y = std::min(low_y, y);
    high_y = std::max(high_y, y);
  };
  // Every half pixel along the image rectangle's border (pixel centres at integers).
  const double right = calibration.image_width - 0.5;
  const double bottom = calibration.image_height - 0.5;
  std::vector<Eigen::Vector2d> border;
  for (double x = -0.5; x <= right; x += 0.5) {
    border.emplace_back(x, -0.5);
    border.emplace_back(x, bottom);
  }
  for (double y = -0.5; y <= bottom; y += 0.5) {
    border.emplace_back(-0.5, y);
    border.emplace_back(right, y);
  }
  border.emplace_back(calibration.cx, calibration.cy);  // the axis: the view is never empty
  for (const Eigen::Vector2d& pixel : border) {
    const std::optional<Eigen::Vector3d> ray = lens.unproject(pixel);
    if (ray && ray->allFinite() && ray->z() > 0.0 && std::acos(std::clamp(ray->normalized().z(), -1.0, 1.0)) <= max_angle) {
      include(ray->x() / ray->z(), ray->y() / ray->z());
    } else {
      // Beyond the angle the compositor draws (or the model's range): the view reaches the cap
      // on the side of the pixel, and on both sides along an axis the pixel is near.
      const double side_x = pixel.x() - calibration.cx;
      const double side_y = pixel.y() - calibration.cy;
      include(side_x >= 0.0 ? max_tan : -max_tan, side_y >= 0.0 ? max_tan : -max_tan);
      include(side_x > 0.0 ? max_tan : -max_tan, side_y > 0.0 ? max_tan : -max_tan);
    }
  }
  low_x = std::max(low_x, -max_tan);
  high_x = std::min(high_x, max_tan);
  low_y = std::max(low_y, -max_tan);
  high_y = std::min(high_y, max_tan);
  // Pixel -0.5 at the lowest bound, width − 0.5 at (or beyond) the highest.
  view.cx = -0.5 - view.fx * low_x;
  view.cy = -0.5 - view.fy * low_y;
  view.width = static_cast<int>(std::ceil(view.fx * (high_x - low_x)));
  view.height = static_cast<int>(std::ceil(view.fy * (high_y - low_y)));
  return view;
}

bool plane_in_view(const geom::Plane& plane, const CameraPose& pose, const camera::CameraCalibration& calibration,
                   double margin_px) {
  PlaneViewOptions options;
  options.margin_px = margin_px;
  return plane_in_view(plane, pose, undistorted_view(calibration), options);
}

}  // namespace skylit::render
