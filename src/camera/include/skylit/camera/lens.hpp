#pragma once
// A calibrated camera's lens: pixels to directions and back, in the camera and the site frame
// (fisheye Kannala–Brandt or pinhole with OpenCV's distortion).
#include <optional>

#include <Eigen/Core>

#include "skylit/camera/calibration.hpp"

namespace skylit::camera {

// Lens model of a calibration, in the camera frame (OpenCV: x right, y down, z forward).
class Lens {
 public:
  // InputError naming the calibration's field for numbers that parse but describe no camera: an
  // image that spans less than a degree, a principal point far outside the image, a distortion
  // that folds back inside the image.
  explicit Lens(const CameraCalibration& calibration);

  // Pixel (x, y) of a camera-frame direction; nullopt when the model cannot image it (behind a
  // pinhole camera, beyond the fisheye model's monotonic range).
  std::optional<Vec2> project(const Vec3& camera_direction) const;
  // Unit camera-frame direction of a pixel position (inverse of project, Newton on θ_d for the
  // fisheye; iterative undistortion for the pinhole). nullopt outside the invertible range.
  std::optional<Vec3> unproject(const Vec2& pixel) const;
  // The same in the site frame (R_site_from_camera applied).
  std::optional<Vec3> pixel_to_site(const Vec2& pixel) const;
  std::optional<Vec2> site_to_pixel(const Vec3& site_direction) const;

  // Largest angle from the optical axis (radians) the model images monotonically.
  double max_theta() const { return max_theta_; }
  const CameraCalibration& calibration() const { return calibration_; }

 private:
  double distort_theta(double theta) const;   // θ_d(θ) of the fisheye model
  void check_describes_a_camera() const;
  CameraCalibration calibration_;
  Eigen::Matrix3d camera_from_site_;
  double max_theta_ = 0;
};

}  // namespace skylit::camera
