// The pixel-to-ray table of the HMD camera and the pinhole camera that covers it.
#include "skylit/render/lens_remap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::render {

std::optional<Eigen::Vector2d> PinholeCamera::project(const Eigen::Vector3d& camera_point) const {
  if (!(camera_point.z() > 0.0)) return std::nullopt;
  return Eigen::Vector2d(fx * camera_point.x() / camera_point.z() + cx,
                         fy * camera_point.y() / camera_point.z() + cy);
}

LensRemap make_lens_remap(const camera::Lens& lens, const LensRemapOptions& options) {
  const camera::CameraCalibration& calibration = lens.calibration();
  const int width = calibration.image_width;
  const int height = calibration.image_height;
  const double max_angle = std::clamp(options.max_angle_deg, 1.0, 89.0) * std::numbers::pi / 180.0;
  const double min_z = std::cos(max_angle);

  LensRemap remap;
  remap.rays = cv::Mat(height, width, CV_32FC4, cv::Scalar::all(0));
  double low_x = std::numeric_limits<double>::infinity(), high_x = -low_x;
  double low_y = low_x, high_y = -low_x;
  for (int y = 0; y < height; ++y) {
    auto* row = remap.rays.ptr<cv::Vec4f>(y);
    for (int x = 0; x < width; ++x) {
      const std::optional<Eigen::Vector3d> ray = lens.unproject(Eigen::Vector2d(x, y));
      if (!ray || !ray->allFinite() || ray->z() < min_z) continue;
      const Eigen::Vector3d d = ray->normalized();
      row[x] = cv::Vec4f(static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(d.z()), 1.0f);
      low_x = std::min(low_x, d.x() / d.z());
      high_x = std::max(high_x, d.x() / d.z());
      low_y = std::min(low_y, d.y() / d.z());
      high_y = std::max(high_y, d.y() / d.z());
      ++remap.valid_pixels;
    }
  }
  if (remap.valid_pixels == 0) {
    throw InputError(input_message(calibration.file, -1, -1, "",
                                   "no pixel of the HMD camera's image can be unprojected through its lens model",
                                   "check fx, fy, cx, cy and D of the HMD camera's calibration"));
  }

  // Focal lengths as the camera's (times render_scale): where the lens is nearly a pinhole (the
  // centre of the image) one render texel is one camera pixel. Shrunk when the extent would pass
  // max_size. One texel of margin on each side keeps every bilinear lookup inside.
  double scale = std::max(options.render_scale, 1e-3);
  const double extent = std::max((high_x - low_x) * calibration.fx, (high_y - low_y) * calibration.fy);
  const double limit = std::max(options.max_size, 16) - 4;
  if (extent * scale > limit) scale = limit / extent;
  PinholeCamera& pinhole = remap.pinhole;
  pinhole.fx = calibration.fx * scale;
  pinhole.fy = calibration.fy * scale;
  pinhole.cx = 1.0 - low_x * pinhole.fx;
  pinhole.cy = 1.0 - low_y * pinhole.fy;
  pinhole.width = static_cast<int>(std::ceil((high_x - low_x) * pinhole.fx)) + 3;
  pinhole.height = static_cast<int>(std::ceil((high_y - low_y) * pinhole.fy)) + 3;
  return remap;
}

}  // namespace skylit::render
