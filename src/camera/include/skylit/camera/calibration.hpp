#pragma once
// A camera's calibration: image size, lens model and coefficients, and its pose on the site;
// read from our YAML schema or OpenCV's FileStorage, validated, written back.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace skylit::camera {

using Vec3 = Eigen::Vector3d;
using Vec2 = Eigen::Vector2d;

enum class LensModel { Fisheye, Pinhole };

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

}  // namespace skylit::camera
