#pragma once
// Temporal smoothing of the luminance parameters: a sky camera's frames carry noise and
// flicker (exposure steps, compression) that would make shadows shimmer.
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/sky/sky_estimate.hpp"

namespace skylit::sky {

// Each frame moves the smoothed S towards the new one by
//
//     α = 1 − exp(−Δt / τ)         Δt: time since the previous frame, τ: the time constant
//
// the exact discretisation of a first-order low-pass for a sky held between frames, so that the
// response depends on elapsed time, not on the frame rate: after a step the smoothed value has
// covered 1 − exp(−t/τ) of it at time t, whatever the frame spacing. The sun's energy is
// smoothed the same way; its direction is taken as measured.
//
// The sky also jumps for real: when the sun appears or disappears (a cloud's edge), smoothing
// would fade a shadow in or out over τ, so the smoother restarts from the new frame instead.
class SkySmoother {
 public:
  // time_constant_s: τ in seconds, 0 = off (every frame passes unchanged). InputError when
  // negative or not finite.
  explicit SkySmoother(double time_constant_s = 0.0);

  // Takes the frame at `timestamp_s` (seconds, any origin) with its S (one RGB value per dome
  // face) and the sun's energy (none without a sun). Restarts from this frame when it is the
  // first, when the sun appeared or disappeared, when the face count changed, or when time ran
  // backwards (a replayed recording); a repeated timestamp changes nothing. InputError for a
  // non-finite timestamp or value.
  void update(double timestamp_s, std::span<const Eigen::Vector3d> S, const std::optional<Eigen::Vector3d>& sun_energy);

  // The same for a sky stage result: returns it with S and the sun's energy smoothed.
  SkyEstimate smooth(double timestamp_s, SkyEstimate estimate);

  std::span<const Eigen::Vector3d> S() const { return S_; }
  const std::optional<Eigen::Vector3d>& sun_energy() const { return sun_energy_; }
  bool restarted() const { return restarted_; }   // the last update restarted from its frame
  double time_constant() const { return time_constant_; }
  void reset() { started_ = false; }              // the next update restarts

 private:
  double time_constant_;
  bool started_ = false;
  bool restarted_ = false;
  double last_time_ = 0.0;
  std::vector<Eigen::Vector3d> S_;
  std::optional<Eigen::Vector3d> sun_energy_;
};

}  // namespace skylit::sky
