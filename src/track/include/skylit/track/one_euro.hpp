#pragma once
// The One Euro filter (Casiez, Roussel, Vogel, CHI 2012): a low-pass filter whose cutoff rises
// with speed, so a still head is steady (low cutoff: jitter removed) and a moving head is
// followed closely (high cutoff: little lag).
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "skylit/track/pose.hpp"

namespace skylit::track {

// The filter at each step:
//
//   cutoff = min_cutoff + beta · |filtered speed|,  speed filtered at d_cutoff
//   alpha  = 1 / (1 + 1 / (2π · cutoff · Δt))
struct OneEuroSettings {
  bool enabled = true;
  double min_cutoff = 1.0;  // Hz: the cutoff at rest; lower removes more jitter, lags more
  double beta = 0.5;        // Hz per unit/s of speed: higher follows fast motion with less lag
  double d_cutoff = 1.0;    // Hz: the cutoff of the speed estimate
};

// The smoothing factor of a first-order low-pass filter at `cutoff` Hz over `dt` seconds.
double one_euro_alpha(double cutoff, double dt);

// A vector (position, metres; beta in Hz per m/s).
class OneEuroVector {
 public:
  explicit OneEuroVector(const OneEuroSettings& settings = {}) : settings_(settings) {}
  // The filtered value at time t; a t not after the previous one returns the previous output.
  Vec3 filter(double t, const Vec3& x);
  void reset() { started_ = false; }

 private:
  OneEuroSettings settings_;
  bool started_ = false;
  double t_ = 0;
  Vec3 x_ = Vec3::Zero();
  Vec3 dx_ = Vec3::Zero();
};

// A rotation (beta in Hz per rad/s): the speed is the angular velocity, the low-pass a slerp.
class OneEuroRotation {
 public:
  explicit OneEuroRotation(const OneEuroSettings& settings = {}) : settings_(settings) {}
  Eigen::Quaterniond filter(double t, const Eigen::Quaterniond& q);
  void reset() { started_ = false; }

 private:
  OneEuroSettings settings_;
  bool started_ = false;
  double t_ = 0;
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Vec3 w_ = Vec3::Zero();
};

// Position and rotation of a pose, each with its own settings.
class OneEuroPose {
 public:
  OneEuroPose(const OneEuroSettings& position, const OneEuroSettings& rotation)
      : position_(position), rotation_(rotation) {}
  Pose filter(const Pose& pose);
  void reset();

 private:
  OneEuroVector position_;
  OneEuroRotation rotation_;
};

}  // namespace skylit::track
