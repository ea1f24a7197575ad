#pragma once
// Photos of a flat board seen through a known lens at a known pose, for the calibration tests:
// each pixel is the mean of s × s sub-pixel rays (unprojected once per lens), intersected with
// the board's plane.
#include <functional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "skylit/camera/calibration.hpp"

namespace skylit::calib_test {

struct BoardPose {
  Eigen::Matrix3d R_camera_from_board = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_camera_from_board = Eigen::Vector3d(0, 0, 1);  // metres
};

// The pose that puts the board point `board_centre` (metres, z = 0) at `distance` along the
// camera direction (theta from the optical axis, phi around it, radians), the board facing the
// camera, then tilted about its own x and y axes and rolled about its normal (radians).
BoardPose board_pose(const Eigen::Vector2d& board_centre, double theta, double phi, double distance, double tilt_x, double tilt_y,
                     double roll);

// Board reflectance at board coordinates (x, y) metres; the background where the ray misses.
using BoardPattern = std::function<float(double x, double y)>;

// A chessboard of `inner` inner corners (corner (c, r) at (c, r) × square), squares from −square
// to inner × square, inside a white margin of one square. Black 0.08, white 0.92.
BoardPattern chessboard_pattern(cv::Size inner, double square);

class BoardRenderer {
 public:
  BoardRenderer(const camera::CameraCalibration& lens, int supersample);
  // CV_8UC1: the board where the rays hit it (front or back), `background` elsewhere and where
  // the lens images nothing; a little sensor noise (σ = `noise` in 0..255 units, fixed seed).
  cv::Mat render(const BoardPattern& pattern, const BoardPose& pose, float background = 0.45f, double noise = 1.0) const;

 private:
  int width_, height_, supersample_;
  std::vector<Eigen::Vector3f> rays_;  // per sub-pixel, unit camera-frame; zero where none
};

}  // namespace skylit::calib_test
