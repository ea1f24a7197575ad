#pragma once
// A synthetic head for the fusion tests: a known trajectory (yaw, pitch and roll sinusoids on a
// camera looking north, a small sway of the position), the gyro and accelerometer an IMU on it
// would read (exact derivatives, then white noise and a constant bias), and camera poses with
// noise as the marker tracker would give them.
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "skylit/track/imu.hpp"
#include "skylit/track/pose.hpp"

namespace synthetic {

using Eigen::Matrix3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kGravity = 9.80665;

struct Wave {
  double amplitude = 0, frequency = 0, phase = 0;  // rad (or m), Hz, rad
  double value(double t) const { return amplitude * std::sin(kTwoPi * frequency * t + phase); }
  double rate(double t) const { return amplitude * kTwoPi * frequency * std::cos(kTwoPi * frequency * t + phase); }
  double acceleration(double t) const {
    return -amplitude * kTwoPi * kTwoPi * frequency * frequency * std::sin(kTwoPi * frequency * t + phase);
  }
};

struct Head {
  // R_site_from_camera(t) = Rz_site(yaw) · R0 · Rx_camera(pitch) · Rz_camera(roll), R0 looking north.
  std::vector<Wave> yaw{{0.8, 0.25, 0.0}, {0.3, 0.7, 1.0}};
  std::vector<Wave> pitch{{0.25, 0.4, 0.5}};
  std::vector<Wave> roll{{0.1, 0.3, 0.2}};
  std::vector<Wave> x{{0.05, 0.3, 0.0}}, y{{0.03, 0.5, 1.0}}, z{{0.02, 0.2, 0.0}};
  Vector3d origin{0.0, 0.0, 1.6};

  static double sum(const std::vector<Wave>& waves, double t) {
    double s = 0;
    for (const auto& w : waves) s += w.value(t);
    return s;
  }
  static double sum_rate(const std::vector<Wave>& waves, double t) {
    double s = 0;
    for (const auto& w : waves) s += w.rate(t);
    return s;
  }
  static double sum_acceleration(const std::vector<Wave>& waves, double t) {
    double s = 0;
    for (const auto& w : waves) s += w.acceleration(t);
    return s;
  }
  static Matrix3d north() {
    Matrix3d R0;  // camera x → east, y → down, z → north
    R0.col(0) = Vector3d::UnitX();
    R0.col(1) = -Vector3d::UnitZ();
    R0.col(2) = Vector3d::UnitY();
    return R0;
  }

  Quaterniond rotation(double t) const {
    const Matrix3d R = Eigen::AngleAxisd(sum(yaw, t), Vector3d::UnitZ()).toRotationMatrix() * north() *
                       Eigen::AngleAxisd(sum(pitch, t), Vector3d::UnitX()).toRotationMatrix() *
                       Eigen::AngleAxisd(sum(roll, t), Vector3d::UnitZ()).toRotationMatrix();
    return Quaterniond(R).normalized();
  }
  // The angular velocity in the camera frame: ω = (B C D)ᵀ ẏaw e_z + Dᵀ ṗitch e_x + ṙoll e_z.
  Vector3d angular_velocity(double t) const {
    const Matrix3d C = Eigen::AngleAxisd(sum(pitch, t), Vector3d::UnitX()).toRotationMatrix();
    const Matrix3d D = Eigen::AngleAxisd(sum(roll, t), Vector3d::UnitZ()).toRotationMatrix();
    return (north() * C * D).transpose() * (sum_rate(yaw, t) * Vector3d::UnitZ()) +
           D.transpose() * (sum_rate(pitch, t) * Vector3d::UnitX()) + sum_rate(roll, t) * Vector3d::UnitZ();
  }
  Vector3d position(double t) const { return origin + Vector3d(sum(x, t), sum(y, t), sum(z, t)); }
  Vector3d acceleration(double t) const {
    return Vector3d(sum_acceleration(x, t), sum_acceleration(y, t), sum_acceleration(z, t));
  }
  skylit::track::Pose pose(double t) const {
    skylit::track::Pose p;
    p.timestamp = t;
    p.R_site_from_camera = rotation(t);
    p.t_site_from_camera = position(t);
    return p;
  }
};

struct ImuModel {
  double rate = 500;            // Hz
  double noise_density = 1e-3;  // rad/s/√Hz (about 4× a BMI055's)
  Vector3d bias{0.02, -0.015, 0.01};  // rad/s, IMU frame
  double accel_noise = 0.02;    // m/s² per sample
  Quaterniond R_camera_from_imu = Quaterniond(0, 1, 0, 0);  // a half turn about x: the DS4 on top of the HMD
};

// IMU samples over [t0, t1) in the IMU frame.
inline std::vector<skylit::track::ImuSample> imu_samples(const Head& head, const ImuModel& model, double t0, double t1,
                                                        unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma = model.noise_density * std::sqrt(model.rate);
  std::vector<skylit::track::ImuSample> samples;
  const Matrix3d imu_from_camera = model.R_camera_from_imu.conjugate().toRotationMatrix();
  for (long k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / model.rate;
    if (t >= t1) break;
    skylit::track::ImuSample s;
    s.timestamp = t;
    const Vector3d noise(normal(rng), normal(rng), normal(rng));
    s.gyro = imu_from_camera * head.angular_velocity(t) + model.bias + sigma * noise;
    const Vector3d specific_force = head.rotation(t).conjugate() * (head.acceleration(t) + kGravity * Vector3d::UnitZ());
    s.accel = imu_from_camera * specific_force + model.accel_noise * Vector3d(normal(rng), normal(rng), normal(rng));
    samples.push_back(s);
  }
  return samples;
}

struct CameraModel {
  double rate = 30;                  // Hz
  double rotation_sigma = 0.005;     // rad per axis
  double position_sigma = 0.005;     // m per axis
  double latency = 0.040;            // s from the frame's time to the pose's arrival
  double gap_start = 1e300, gap_end = 1e300;  // no tags seen in [gap_start, gap_end)
};

struct TimedPose {
  double arrival = 0;
  skylit::track::Pose pose;
};

inline std::vector<TimedPose> camera_poses(const Head& head, const CameraModel& model, double t0, double t1, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<TimedPose> poses;
  for (long k = 0;; ++k) {
    const double t = t0 + static_cast<double>(k) / model.rate;
    if (t >= t1) break;
    if (t >= model.gap_start && t < model.gap_end) continue;
    skylit::track::Pose p = head.pose(t);
    const Vector3d dtheta = model.rotation_sigma * Vector3d(normal(rng), normal(rng), normal(rng));
    p.R_site_from_camera = (p.R_site_from_camera * Quaterniond(Eigen::AngleAxisd(dtheta.norm(), dtheta.normalized()))).normalized();
    p.t_site_from_camera += model.position_sigma * Vector3d(normal(rng), normal(rng), normal(rng));
    poses.push_back({t + model.latency, p});
  }
  return poses;
}

inline double degrees(double radians) { return radians * 180.0 / std::numbers::pi; }

}  // namespace synthetic
