#pragma once
// A stereo camera's calibration (a camera per eye): each camera in the calibration schema, under
// left: and right:, and the right camera's pose relative to the left; read, validated, written.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "skylit/camera/calibration.hpp"

namespace skylit::camera {

// The YAML schema (docs/calibration.md, "Stereo cameras"), written by skylit-calib stereo:
//
//   left:                       # the calibration schema of calibration.hpp
//     image_width: 640
//     ...
//   right:
//     ...
//   R_right_from_left: [1,0,0, 0,1,0, 0,0,1]   # row-major: x_right = R x_left + t
//   t_right_from_left: [-0.064, 0, 0]          # metres; its length is the baseline
//   rms: 0.21                                  # optional: over both cameras, pixels
//   per_pair_errors: [0.2, 0.3]                # optional, pixels
struct StereoCalibration {
  std::filesystem::path file;  // where it came from (messages); may be empty
  CameraCalibration left, right;
  Eigen::Matrix3d R_right_from_left = Eigen::Matrix3d::Identity();
  Vec3 t_right_from_left = Vec3::Zero();  // metres
  std::optional<double> rms;              // reprojection error over both cameras, pixels
  std::vector<double> per_pair_errors;    // pixels

  double baseline_m() const { return t_right_from_left.norm(); }
};

// The cameras closer than this are taken for a mistake (a zero or millimetre baseline).
constexpr double kMinBaselineM = 0.001;

// InputError naming the file, line and field (left.fx, R_right_from_left, ...) and the fix for
// anything missing or wrong: a field missing, R_right_from_left not a rotation, a baseline under
// kMinBaselineM.
StereoCalibration load_stereo_calibration(const std::filesystem::path& file);
std::string stereo_calibration_to_yaml(const StereoCalibration& calibration);
// Writes stereo_calibration_to_yaml atomically.
void save_stereo_calibration(const StereoCalibration& calibration, const std::filesystem::path& file);
// Throws InputError (naming calibration.file and the field) when a value is out of range.
void validate(const StereoCalibration& calibration);

}  // namespace skylit::camera
