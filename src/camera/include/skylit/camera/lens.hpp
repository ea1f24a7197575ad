#pragma once
// A calibrated camera's lens: pixels to directions and back, in the camera and the site frame
// (fisheye Kannala–Brandt or pinhole with OpenCV's distortion).
#include <cmath>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "skylit/camera/calibration.hpp"

namespace skylit::camera {

namespace lens_model {

// θ_d(θ) = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸), the fisheye (Kannala–Brandt) model.
template <typename T>
T fisheye_distort(const std::vector<double>& k, const T& theta) {
  const T t2 = theta * theta;
  return theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}

// OpenCV's pinhole distortion of a normalised point: radial (rational with 8 coefficients) and
// tangential.
template <typename T>
Eigen::Matrix<T, 2, 1> pinhole_distort(const std::vector<double>& D, const T& x, const T& y) {
  const double k1 = D[0], k2 = D[1], p1 = D[2], p2 = D[3], k3 = D[4];
  const T r2 = x * x + y * y;
  T g = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  if (D.size() >= 8) g = g / (1.0 + r2 * (D[5] + r2 * (D[6] + r2 * D[7])));
  return {x * g + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x), y * g + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

}  // namespace lens_model

// Lens model of a calibration, in the camera frame (OpenCV: x right, y down, z forward).
class Lens {
 public:
  // InputError naming the calibration's field for numbers that parse but describe no camera: an
  // image that spans less than a degree, a principal point far outside the image, a distortion
  // that folds back inside the image.
  explicit Lens(const CameraCalibration& calibration);

  // Pixel (x, y) of a camera-frame direction; nullopt when the model cannot image it (behind a
  // pinhole camera, beyond the fisheye model's monotonic range).
  std::optional<Vec2> project(const Vec3& camera_direction) const { return project_as<double>(camera_direction); }
  // project() for any scalar type whose math functions argument-dependent lookup finds: double,
  // or an automatic differentiation's dual numbers (a solver's exact Jacobians through the lens).
  template <typename T>
  std::optional<Eigen::Matrix<T, 2, 1>> project_as(const Eigen::Matrix<T, 3, 1>& camera_direction) const;
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

template <typename T>
std::optional<Eigen::Matrix<T, 2, 1>> Lens::project_as(const Eigen::Matrix<T, 3, 1>& direction) const {
  using std::abs;
  using std::atan2;
  using std::isfinite;
  using std::sqrt;
  if (!isfinite(direction.x()) || !isfinite(direction.y()) || !isfinite(direction.z())) return std::nullopt;
  // Scaled to a largest component of 1 (a lens sees no length), so that squares neither overflow
  // nor underflow at any length.
  T largest = abs(direction.x());
  if (abs(direction.y()) > largest) largest = abs(direction.y());
  if (abs(direction.z()) > largest) largest = abs(direction.z());
  if (largest == 0.0) return std::nullopt;
  const Eigen::Matrix<T, 3, 1> d = direction / largest;
  const T rho2 = d.x() * d.x() + d.y() * d.y();
  if (rho2 == 0.0 && d.z() <= 0.0) return std::nullopt;  // zero vector, or straight behind
  const CameraCalibration& c = calibration_;
  Eigen::Matrix<T, 2, 1> m;
  if (c.model == LensModel::Fisheye) {
    if (rho2 == 0.0) {
      m.setZero();  // on the axis (sqrt's derivative is infinite there)
    } else {
      const T rho = sqrt(rho2);
      const T theta = atan2(rho, d.z());
      if (theta > max_theta_) return std::nullopt;
      const T scale = lens_model::fisheye_distort(c.D, theta) / rho;
      m = Eigen::Matrix<T, 2, 1>(d.x() * scale, d.y() * scale);
    }
  } else {
    if (d.z() <= 0.0) return std::nullopt;
    if (rho2 != 0.0 && atan2(sqrt(rho2), d.z()) > max_theta_) return std::nullopt;
    m = lens_model::pinhole_distort(c.D, T(d.x() / d.z()), T(d.y() / d.z()));
  }
  return Eigen::Matrix<T, 2, 1>(c.fx * m.x() + c.cx, c.fy * m.y() + c.cy);
}

}  // namespace skylit::camera
