#include "skylit/track/fusion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "so3.hpp"

namespace skylit::track {
namespace {

double square(double x) { return x * x; }

// 1 at x ≤ 0, 0 at x ≥ 1, smooth between (the building fades, it does not blink).
double fade(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return 1.0 - x * x * (3.0 - 2.0 * x);
}

}  // namespace

const char* to_string(TrackingState state) {
  switch (state) {
    case TrackingState::Initializing: return "initializing";
    case TrackingState::Tracking: return "tracking";
    case TrackingState::Coasting: return "coasting";
    case TrackingState::Lost: return "lost";
  }
  return "?";
}

const char* to_string(ImuLink link) {
  switch (link) {
    case ImuLink::None: return "none";
    case ImuLink::Live: return "live";
    case ImuLink::Gone: return "gone";
  }
  return "?";
}

PoseFusion::PoseFusion(const FusionSettings& settings)
    : settings_(settings), jitter_(settings.position_filter, settings.rotation_filter) {
  settings_.R_camera_from_imu.normalize();
  bias_P_ = Eigen::Matrix3d::Identity() * square(settings_.initial_bias_sigma);
}

// One gyro step from `from` to `to` (to.t and to.omega set): the rate is the mean of the two
// samples (trapezoidal rule), less the bias; the error covariance follows the error dynamics
// δθ' = −[ω]× δθ − δb − n_g, δb' = n_b.
void PoseFusion::propagate(const Entry& from, Entry& to) const {
  const double dt = to.t - from.t;
  const Eigen::Vector3d rate = 0.5 * (from.omega + to.omega) - from.bias;
  const Eigen::Quaterniond step = so3::exp(rate * dt);
  to.q = (from.q * step).normalized();
  to.bias = from.bias;
  // P' = F P Fᵀ with F = [R −dt·I; 0 I] (R = step's transpose), by blocks: P = [A B; Bᵀ C].
  const Eigen::Matrix3d R = step.toRotationMatrix().transpose();
  const Eigen::Matrix3d A = from.P.topLeftCorner<3, 3>();
  const Eigen::Matrix3d B = from.P.topRightCorner<3, 3>();
  const Eigen::Matrix3d C = from.P.bottomRightCorner<3, 3>();
  const Eigen::Matrix3d top_right = R * B - dt * C;
  Eigen::Matrix3d top_left = (R * A - dt * B.transpose()) * R.transpose() - dt * top_right;
  top_left.diagonal().array() += square(settings_.gyro_noise) * dt;
  to.P.topLeftCorner<3, 3>() = 0.5 * (top_left + top_left.transpose());
  to.P.topRightCorner<3, 3>() = top_right;
  to.P.bottomLeftCorner<3, 3>() = top_right.transpose();
  to.P.bottomRightCorner<3, 3>() = C;
  to.P.bottomRightCorner<3, 3>().diagonal().array() += square(settings_.gyro_bias_walk) * dt;
}

// The Kalman update with a camera orientation: residual in the filter's local frame, H = [I 0].
void PoseFusion::camera_update(Entry& entry, const Eigen::Quaterniond& measured) const {
  const Eigen::Vector3d residual = so3::log(entry.q.conjugate() * measured);
  Eigen::Matrix3d S = entry.P.topLeftCorner<3, 3>();
  S.diagonal().array() += square(settings_.camera_rotation_sigma);
  const Eigen::Matrix<double, 6, 3> K = entry.P.leftCols<3>() * S.inverse();
  const Eigen::Matrix<double, 6, 1> dx = K * residual;
  entry.q = (entry.q * so3::exp(dx.head<3>())).normalized();
  entry.bias += dx.tail<3>();
  // Joseph form: stays symmetric and positive.
  Mat6 IKH = Mat6::Identity();
  IKH.leftCols<3>() -= K;
  entry.P = IKH * entry.P * IKH.transpose() + square(settings_.camera_rotation_sigma) * K * K.transpose();
}

// Integrates again from entry `first` (≥ 1) to the newest, re-applying the camera updates.
void PoseFusion::recompute_from(std::size_t first) {
  for (std::size_t k = std::max<std::size_t>(first, 1); k < history_.size(); ++k) {
    propagate(history_[k - 1], history_[k]);
    if (history_[k].camera) camera_update(history_[k], history_[k].measured);
  }
}

// A camera entry between two IMU samples takes the rate interpolated between them (held from the
// one before while the one after has not come). Called when the sample at `sample` arrives, for
// the camera entries on either side of it; returns the first entry whose rate changed (`sample`
// when none did).
std::size_t PoseFusion::refresh_camera_rates(std::size_t sample) {
  if (sample == 0) return 0;
  std::size_t j = sample;
  while (j > 1 && !history_[j - 1].sample) --j;  // history_[j .. sample-1] are camera entries
  for (std::size_t k = j; k < sample; ++k) history_[k].omega = interpolate_rate(history_[j - 1], history_[sample], history_[k].t);
  std::size_t next = sample + 1;
  while (next < history_.size() && !history_[next].sample) ++next;  // camera entries up to the next sample
  for (std::size_t k = sample + 1; k < next; ++k) {
    history_[k].omega = next < history_.size() ? interpolate_rate(history_[sample], history_[next], history_[k].t)
                                               : history_[sample].omega;
  }
  return j;
}

Eigen::Vector3d PoseFusion::interpolate_rate(const Entry& before, const Entry& after, double t) {
  const double s = (t - before.t) / (after.t - before.t);
  return (1.0 - s) * before.omega + s * after.omega;
}

void PoseFusion::trim_history() {
  const double keep_from = history_.back().t - settings_.history;
  while (history_.size() > 2 && history_[1].t <= keep_from) history_.pop_front();
  bias_ = history_.back().bias;
  bias_P_ = history_.back().P.bottomRightCorner<3, 3>();
}

// The filter starts (or starts again after an IMU outage) at time t: the orientation from the
// last camera pose when there is one (uncertain by how far the head may have turned since), else
// unknown (the first camera pose sets it); the bias as it was.
void PoseFusion::reseed_orientation(double t) {
  Entry seed;
  seed.t = t;
  double sigma = std::numbers::pi;
  if (last_camera_) {
    seed.q = last_camera_->R_site_from_camera;
    const double age = std::max(0.0, t - last_camera_->timestamp);
    sigma = std::min(std::numbers::pi, settings_.camera_rotation_sigma + 2.0 * age);  // up to 2 rad/s of head turn
  }
  seed.bias = bias_;
  seed.P.setZero();
  seed.P.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity() * square(sigma);
  seed.P.bottomRightCorner<3, 3>() = bias_P_;
  history_.clear();
  history_.push_back(seed);
}

void PoseFusion::add_imu(const ImuSample& sample) {
  const std::lock_guard lock(mutex_);
  ++counters_.imu_samples;
  Entry entry;
  entry.t = sample.timestamp;
  entry.omega = settings_.R_camera_from_imu * sample.gyro;
  imu_seen_ = true;

  if (history_.empty() || entry.t > newest_imu_ + settings_.imu_timeout) {
    reseed_orientation(entry.t);
    history_.back().omega = entry.omega;
    history_.back().sample = true;
    newest_imu_ = entry.t;
    return;
  }
  newest_imu_ = std::max(newest_imu_, entry.t);
  if (entry.t < history_.front().t) {
    ++counters_.out_of_order_imu_samples;
    return;
  }
  // Usually appended; a sample from the past (USB reordering, a camera pose that came ahead of
  // it) is inserted at its time and everything after it integrated again.
  const auto after = std::upper_bound(history_.begin(), history_.end(), entry.t,
                                      [](double t, const Entry& e) { return t < e.t; });
  std::size_t index = static_cast<std::size_t>(after - history_.begin());
  if (history_[index - 1].t == entry.t) {
    if (history_[index - 1].sample) return;  // a repeated sample
    --index;  // a camera entry at the same time: the sample joins it
    history_[index].sample = true;
    history_[index].omega = entry.omega;
  } else {
    entry.sample = true;
    history_.insert(history_.begin() + static_cast<std::ptrdiff_t>(index), entry);
  }
  recompute_from(refresh_camera_rates(index));
  trim_history();
}

std::size_t PoseFusion::add_imu_from(ImuSource& source, double until) {
  std::vector<ImuSample> samples;
  const std::size_t count = source.read(samples, until);
  const Eigen::Quaterniond R = source.R_camera_from_imu().normalized();
  const Eigen::Quaterniond to_settings = settings_.R_camera_from_imu.conjugate() * R;
  for (ImuSample& sample : samples) {
    sample.gyro = to_settings * sample.gyro;  // add_imu applies the settings' rotation
    sample.accel = to_settings * sample.accel;
    add_imu(sample);
  }
  return count;
}

// Per axis: state (p, v), white-acceleration process noise, measurement p.
void PoseFusion::update_position(const Pose& pose) {
  PositionFilter& f = position_;
  const double r = square(settings_.camera_position_sigma);
  if (!f.started || pose.timestamp - f.t > settings_.camera_timeout) {
    // First pose, or back after a gap: the velocity from before means nothing now.
    f.started = true;
    f.t = pose.timestamp;
    f.p = pose.t_site_from_camera;
    f.v.setZero();
    f.P << r, 0, 0, 1.0;
    return;
  }
  const double dt = pose.timestamp - f.t;
  f.p += f.v * dt;
  Eigen::Matrix2d F;
  F << 1, dt, 0, 1;
  Eigen::Matrix2d Q;
  Q << dt * dt * dt / 3, dt * dt / 2, dt * dt / 2, dt;
  f.P = F * f.P * F.transpose() + square(settings_.head_acceleration) * Q;
  const double S = f.P(0, 0) + r;
  const Eigen::Vector2d K = f.P.col(0) / S;
  const Eigen::Vector3d innovation = pose.t_site_from_camera - f.p;
  f.p += K(0) * innovation;
  f.v += K(1) * innovation;
  Eigen::Matrix2d IKH = Eigen::Matrix2d::Identity();
  IKH.col(0) -= K;
  f.P = IKH * f.P * IKH.transpose() + r * K * K.transpose();
  f.t = pose.timestamp;
}

ImuLink PoseFusion::imu_link(double t) const {
  if (!imu_seen_) return ImuLink::None;
  return t - newest_imu_ <= settings_.imu_timeout ? ImuLink::Live : ImuLink::Gone;
}

void PoseFusion::add_camera_pose(const Pose& pose_in) {
  const std::lock_guard lock(mutex_);
  ++counters_.camera_poses;
  Pose pose = pose_in;
  pose.R_site_from_camera.normalize();
  const ImuLink imu = imu_link(pose.timestamp);
  const bool live = imu == ImuLink::Live && !history_.empty();
  if (live && pose.timestamp < history_.front().t) {
    ++counters_.late_camera_poses;
    return;
  }

  if (!last_camera_ || pose.timestamp > last_camera_->timestamp) {
    const double limit = imu == ImuLink::Live ? settings_.lost_after : settings_.hold_without_imu;
    if (!last_camera_ || pose.timestamp - last_camera_->timestamp > limit) {
      reacquired_at_ = pose.timestamp;
      reset_jitter_ = true;
    }
    previous_camera_ = last_camera_;
    last_camera_ = pose;
    update_position(pose);
  } else {
    ++counters_.out_of_order_camera_poses;  // still corrects the orientation at its time
  }
  if (!live) return;

  const auto after = std::upper_bound(history_.begin(), history_.end(), pose.timestamp,
                                      [](double t, const Entry& e) { return t < e.t; });
  std::size_t index = static_cast<std::size_t>(after - history_.begin());
  if (history_[index - 1].t == pose.timestamp) {
    --index;  // an entry at the same time: the camera update joins it
  } else {
    Entry entry;
    entry.t = pose.timestamp;
    // The rate interpolated between the samples around it; held from the one before while the
    // camera pose is ahead of the IMU.
    std::size_t previous = index - 1;
    while (previous > 0 && !history_[previous].sample) --previous;
    std::size_t next = index;
    while (next < history_.size() && !history_[next].sample) ++next;
    entry.omega = next < history_.size() ? interpolate_rate(history_[previous], history_[next], entry.t) : history_[previous].omega;
    history_.insert(history_.begin() + static_cast<std::ptrdiff_t>(index), entry);
  }
  history_[index].camera = true;
  history_[index].measured = pose.R_site_from_camera;
  if (index == 0) camera_update(history_[0], history_[0].measured);
  recompute_from(index);
  trim_history();
}

FusedPose PoseFusion::raw_estimate(double t) const {
  FusedPose out;
  out.pose.timestamp = t;
  out.camera_age = std::numeric_limits<double>::infinity();
  out.imu = imu_link(t);
  out.gyro_bias = settings_.R_camera_from_imu.conjugate() * bias_;
  if (!last_camera_) return out;
  out.camera_age = std::max(0.0, t - last_camera_->timestamp);
  const double horizon = settings_.max_prediction;

  if (out.imu == ImuLink::Live && !history_.empty()) {
    const Entry* used = nullptr;
    if (t >= history_.back().t) {
      const Entry& newest = history_.back();
      const double h = std::min(t - newest.t, horizon);
      out.pose.R_site_from_camera = (newest.q * so3::exp((newest.omega - newest.bias) * h)).normalized();
      used = &newest;
    } else if (t <= history_.front().t) {
      out.pose.R_site_from_camera = history_.front().q;
      used = &history_.front();
    } else {
      const auto after = std::upper_bound(history_.begin(), history_.end(), t,
                                          [](double time, const Entry& e) { return time < e.t; });
      const Entry& b = *after;
      const Entry& a = *(after - 1);
      const double s = (t - a.t) / (b.t - a.t);
      out.pose.R_site_from_camera = a.q.slerp(s, b.q).normalized();
      used = &b;
    }
    out.gyro_bias = settings_.R_camera_from_imu.conjugate() * used->bias;
    out.rotation_sigma = std::sqrt(used->P.topLeftCorner<3, 3>().trace() / 3.0);
  } else {
    // Camera poses alone: the rotation extrapolated at the rate of the last two poses.
    const Pose& last = *last_camera_;
    Eigen::Vector3d rate = Eigen::Vector3d::Zero();
    if (previous_camera_) {
      const double dt = last.timestamp - previous_camera_->timestamp;
      if (dt > 0 && dt <= settings_.camera_timeout) {
        rate = so3::log(previous_camera_->R_site_from_camera.conjugate() * last.R_site_from_camera) / dt;
      }
    }
    const double h = std::clamp(t - last.timestamp, -horizon, horizon);
    out.pose.R_site_from_camera = (last.R_site_from_camera * so3::exp(rate * h)).normalized();
    out.rotation_sigma = settings_.camera_rotation_sigma;
  }
  const double h = std::clamp(t - position_.t, -horizon, horizon);
  out.pose.t_site_from_camera = position_.p + position_.v * h;

  const double limit = out.imu == ImuLink::Live ? settings_.lost_after : settings_.hold_without_imu;
  if (out.camera_age <= settings_.camera_timeout) {
    out.state = TrackingState::Tracking;
  } else if (out.camera_age <= limit) {
    out.state = TrackingState::Coasting;
  } else {
    out.state = TrackingState::Lost;
  }
  double confidence = fade((out.camera_age - settings_.camera_timeout) / std::max(1e-9, limit - settings_.camera_timeout));
  if (settings_.reacquire_fade > 0) {
    confidence = std::min(confidence, std::clamp((t - reacquired_at_) / settings_.reacquire_fade, 0.0, 1.0));
  }
  out.confidence = out.state == TrackingState::Lost ? 0.0 : confidence;
  return out;
}

FusedPose PoseFusion::estimate(double timestamp) {
  const std::lock_guard lock(mutex_);
  FusedPose out = raw_estimate(timestamp);
  if (out.state == TrackingState::Initializing || out.state == TrackingState::Lost || reset_jitter_) {
    jitter_.reset();
    last_output_t_ = -std::numeric_limits<double>::infinity();
    reset_jitter_ = false;
    if (out.state == TrackingState::Initializing || out.state == TrackingState::Lost) return out;
  }
  if (timestamp > last_output_t_) {
    // The filter always sees the poses, so that it is in step when the gyro goes.
    const Pose filtered = jitter_.filter(out.pose);
    const bool gyro = out.imu == ImuLink::Live && !settings_.filter_rotation_with_gyro;
    out.pose.t_site_from_camera = filtered.t_site_from_camera;
    if (!gyro) out.pose.R_site_from_camera = filtered.R_site_from_camera;
    last_output_ = out.pose;
    last_output_t_ = timestamp;
  } else if (timestamp == last_output_t_) {
    out.pose = last_output_;
  }
  return out;
}

std::optional<Pose> PoseFusion::pose_at(double timestamp) {
  const FusedPose fused = estimate(timestamp);
  if (fused.state == TrackingState::Initializing || fused.state == TrackingState::Lost) return std::nullopt;
  return fused.pose;
}

std::string PoseFusion::describe() const {
  const std::lock_guard lock(mutex_);
  return std::string("pose fusion (") + (imu_seen_ ? "gyro + " : "") + "camera poses, " +
         std::to_string(counters_.camera_poses) + " camera poses, " + std::to_string(counters_.imu_samples) + " IMU samples)";
}

FusionCounters PoseFusion::counters() const {
  const std::lock_guard lock(mutex_);
  return counters_;
}

}  // namespace skylit::track
