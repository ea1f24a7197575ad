#include "skylit/track/one_euro.hpp"

#include <cmath>
#include <numbers>

#include "so3.hpp"

namespace skylit::track {

double one_euro_alpha(double cutoff, double dt) {
  const double tau = 1.0 / (2.0 * std::numbers::pi * cutoff);
  return 1.0 / (1.0 + tau / dt);
}

Vec3 OneEuroVector::filter(double t, const Vec3& x) {
  if (!settings_.enabled) return x;
  if (!started_) {
    started_ = true;
    t_ = t;
    x_ = x;
    dx_.setZero();
    return x_;
  }
  const double dt = t - t_;
  if (!(dt > 0)) return x_;
  const Vec3 speed = (x - x_) / dt;
  dx_ += one_euro_alpha(settings_.d_cutoff, dt) * (speed - dx_);
  const double cutoff = settings_.min_cutoff + settings_.beta * dx_.norm();
  x_ += one_euro_alpha(cutoff, dt) * (x - x_);
  t_ = t;
  return x_;
}

Eigen::Quaterniond OneEuroRotation::filter(double t, const Eigen::Quaterniond& q) {
  if (!settings_.enabled) return q;
  if (!started_) {
    started_ = true;
    t_ = t;
    q_ = q.normalized();
    w_.setZero();
    return q_;
  }
  const double dt = t - t_;
  if (!(dt > 0)) return q_;
  // The step from the previous output to the input, in the output's frame.
  const Vec3 step = so3::log(q_.conjugate() * q);
  w_ += one_euro_alpha(settings_.d_cutoff, dt) * (step / dt - w_);
  const double cutoff = settings_.min_cutoff + settings_.beta * w_.norm();
  q_ = (q_ * so3::exp(one_euro_alpha(cutoff, dt) * step)).normalized();
  t_ = t;
  return q_;
}

Pose OneEuroPose::filter(const Pose& pose) {
  Pose out = pose;
  out.t_site_from_camera = position_.filter(pose.timestamp, pose.t_site_from_camera);
  out.R_site_from_camera = rotation_.filter(pose.timestamp, pose.R_site_from_camera);
  return out;
}

void OneEuroPose::reset() {
  position_.reset();
  rotation_.reset();
}

}  // namespace skylit::track
