#pragma once
// Camera calibrations (the sky camera's, and later the HMD camera's) and their lens models.
//
// The YAML schema is a contract (other tools write it; see docs/sky.md):
//
//   image_width: 1024
//   image_height: 1024
//   model: fisheye            # fisheye (Kannala–Brandt, D = k1..k4; D = 0 is equidistant)
//                             # or pinhole (D = k1, k2, p1, p2[, k3[, k4, k5, k6]])
//   fx: 325.9
//   fy: 325.9
//   cx: 511.5
//   cy: 511.5
//   D: [0, 0, 0, 0]
//   R_site_from_camera: [1,0,0, 0,1,0, 0,0,1]   # row-major; camera frame is OpenCV's
//   t_site_from_camera: [0, 0, 0]               # optional, metres
//   mask: sky_mask.png                          # optional: 0 where the mount hides the sky
//   rms: 0.21                                   # optional, written by the calibration tools
//   per_view_errors: [0.2, 0.3]                 # optional, pixels
//
// OpenCV FileStorage files (camera_matrix, distortion_coefficients, image_width, image_height,
// and optionally R_site_from_camera) are read too, for users who calibrated with OpenCV's tools.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace skylit::sky {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

enum class LensModel { Fisheye, Pinhole };

struct CameraCalibration {
  std::filesystem::path file;                 // where it came from (messages); may be empty
  int image_width = 0;
  int image_height = 0;
  LensModel model = LensModel::Fisheye;
  double fx = 0, fy = 0, cx = 0, cy = 0;      // pixels; pixel centres at integers (OpenCV)
  std::vector<double> D;                      // 4 (fisheye) or 5 or 8 (pinhole) coefficients
  Eigen::Matrix3d R_site_from_camera = Eigen::Matrix3d::Identity();
  Vec3 t_site_from_camera = Vec3::Zero();
  std::filesystem::path mask;                 // resolved against the file's directory; may be empty
  std::optional<double> rms;                  // reprojection error of the calibration, pixels
  std::vector<double> per_view_errors;        // optional, pixels
};

// Reads the YAML schema above or an OpenCV FileStorage file (.yml/.yaml/.xml/.json with
// camera_matrix). InputError naming the file, line and field for anything missing or wrong.
CameraCalibration load_calibration(const std::filesystem::path& file);
std::string calibration_to_yaml(const CameraCalibration& calibration);
// Writes calibration_to_yaml atomically.
void save_calibration(const CameraCalibration& calibration, const std::filesystem::path& file);
// Throws InputError (naming calibration.file and the field) when a value is out of range.
void validate(const CameraCalibration& calibration);

// Lens model of a calibration, in the camera frame (OpenCV: x right, y down, z forward).
class Lens {
 public:
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
  CameraCalibration calibration_;
  Eigen::Matrix3d camera_from_site_;
  double max_theta_ = 0;
};

}  // namespace skylit::sky
