#include "synthetic_board.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "skylit/camera/lens.hpp"

namespace skylit::calib_test {

BoardPose board_pose(const Eigen::Vector2d& board_centre, double theta, double phi, double distance, double tilt_x, double tilt_y,
                     double roll) {
  const Eigen::Vector3d u(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  // Facing the camera: the board's z axis along the line of sight, its x axis as close to the
  // camera's x as that allows.
  const Eigen::Vector3d z = u;
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d facing;
  facing << x, y, z;
  const Eigen::Matrix3d R = facing * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                            Eigen::AngleAxisd(tilt_x, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                            Eigen::AngleAxisd(tilt_y, Eigen::Vector3d::UnitY()).toRotationMatrix();
  BoardPose pose;
  pose.R_camera_from_board = R;
  pose.t_camera_from_board = distance * u - R * Eigen::Vector3d(board_centre.x(), board_centre.y(), 0.0);
  return pose;
}

BoardPattern chessboard_pattern(cv::Size inner, double square) {
  return [inner, square](double x, double y) -> float {
    const double i = std::floor(x / square) + 1.0;  // squares 0..inner.width
    const double j = std::floor(y / square) + 1.0;
    const bool on_squares = i >= 0 && j >= 0 && i <= inner.width && j <= inner.height;
    const bool on_board = i >= -1 && j >= -1 && i <= inner.width + 1 && j <= inner.height + 1;
    if (!on_board) return -1.0f;  // off the board: background
    if (!on_squares) return 0.92f;
    return (static_cast<long>(i + j) % 2 == 0) ? 0.08f : 0.92f;
  };
}

BoardRenderer::BoardRenderer(const camera::CameraCalibration& calibration, int supersample)
    : width_(calibration.image_width), height_(calibration.image_height), supersample_(supersample) {
  const camera::Lens lens(calibration);
  const int s = supersample_;
  rays_.resize(static_cast<std::size_t>(width_) * height_ * s * s, Eigen::Vector3f::Zero());
  std::size_t k = 0;
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      for (int sy = 0; sy < s; ++sy) {
        for (int sx = 0; sx < s; ++sx, ++k) {
          const camera::Vec2 p(x - 0.5 + (sx + 0.5) / s, y - 0.5 + (sy + 0.5) / s);
          if (const auto d = lens.unproject(p)) rays_[k] = d->cast<float>();
        }
      }
    }
  }
}

cv::Mat BoardRenderer::render(const BoardPattern& pattern, const BoardPose& pose, float background, double noise) const {
  const Eigen::Matrix3f R = pose.R_camera_from_board.cast<float>();
  const Eigen::Vector3f t = pose.t_camera_from_board.cast<float>();
  const Eigen::Vector3f normal = R.col(2);
  const float offset = normal.dot(t);
  const int samples = supersample_ * supersample_;
  std::mt19937 random(7);
  std::normal_distribution<double> gauss(0.0, noise);
  cv::Mat image(height_, width_, CV_8UC1);
  std::size_t k = 0;
  for (int y = 0; y < height_; ++y) {
    auto* row = image.ptr<std::uint8_t>(y);
    for (int x = 0; x < width_; ++x) {
      double sum = 0;
      for (int i = 0; i < samples; ++i, ++k) {
        const Eigen::Vector3f& d = rays_[k];
        float value = background;
        const float along = normal.dot(d);
        if (d.squaredNorm() > 0 && std::abs(along) > 1e-6f) {
          const float distance = offset / along;
          if (distance > 0) {
            const Eigen::Vector3f board = R.transpose() * (distance * d - t);
            const float v = pattern(board.x(), board.y());
            if (v >= 0) value = v;
          }
        }
        sum += value;
      }
      const double code = 255.0 * sum / samples + (noise > 0 ? gauss(random) : 0.0);
      row[x] = static_cast<std::uint8_t>(std::clamp(std::lround(code), 0L, 255L));
    }
  }
  return image;
}

}  // namespace skylit::calib_test
