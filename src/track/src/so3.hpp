#pragma once
// Rotation vectors and quaternions (the exponential map of SO(3)), shared by the jitter filter
// and the fusion. Private to the track module.
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace skylit::track::so3 {

// The rotation by |v| radians about v.
inline Eigen::Quaterniond exp(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle < 1e-9) return Eigen::Quaterniond(1.0, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  const Eigen::Vector3d axis = v / angle;
  const double s = std::sin(0.5 * angle);
  return Eigen::Quaterniond(std::cos(0.5 * angle), s * axis.x(), s * axis.y(), s * axis.z());
}

// The rotation vector of q, angle in [0, π] (the shorter way round).
inline Eigen::Vector3d log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in;
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < 1e-9) return 2.0 * v;
  return (2.0 * std::atan2(s, q.w()) / s) * v;
}

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace skylit::track::so3
