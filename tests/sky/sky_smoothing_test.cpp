// SkySmoother: the step response follows 1 − exp(−t/τ) whatever the frame spacing, a ramp
// lags by τ, the sun's arrival or departure restarts it, and τ = 0 passes frames through.
#include <cmath>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/sky/sky_smoothing.hpp"

namespace skylit::sky {
namespace {

std::vector<Eigen::Vector3d> uniform_sky(int faces, double level) {
  return std::vector<Eigen::Vector3d>(static_cast<std::size_t>(faces), Eigen::Vector3d(level, 2 * level, 3 * level));
}

TEST(SkySmoother, StepResponseDependsOnTimeNotOnFrameRate) {
  const double tau = 2.0;
  // Irregular frame times: 30 fps with dropped frames, then 1 fps.
  std::vector<double> times{0.0};
  for (int k = 1; k <= 45; ++k) times.push_back(k / 30.0 + (k % 7 == 0 ? 0.02 : 0.0));
  for (int k = 1; k <= 5; ++k) times.push_back(1.6 + k);
  SkySmoother smoother(tau);
  smoother.update(times[0], uniform_sky(4, 1.0), std::nullopt);
  EXPECT_TRUE(smoother.restarted());
  for (std::size_t k = 1; k < times.size(); ++k) {
    smoother.update(times[k], uniform_sky(4, 5.0), std::nullopt);  // a step from 1 to 5 at t = 0
    EXPECT_FALSE(smoother.restarted());
    const double expected = 1.0 + 4.0 * (1.0 - std::exp(-times[k] / tau));
    for (const Eigen::Vector3d& s : smoother.S()) {
      EXPECT_NEAR(s.x(), expected, 1e-12);
      EXPECT_NEAR(s.z(), 3.0 * expected, 1e-12);
    }
  }
}

TEST(SkySmoother, RampLagsByTheTimeConstant) {
  // x(t) = t sampled at 10 Hz: the smoothed value trails it by about τ.
  const double tau = 0.5;
  const double dt = 0.1;
  SkySmoother smoother(tau);
  for (int k = 0; k <= 100; ++k) {
    const double t = k * dt;
    smoother.update(t, uniform_sky(1, t), std::nullopt);
  }
  // Steady state of e = x − y: e = (1 − α)(e + dt), so e = dt·a / (1 − a) with a = e^(−dt/τ).
  const double a = std::exp(-dt / tau);
  EXPECT_NEAR(10.0 - smoother.S()[0].x(), dt * a / (1.0 - a), 1e-9);
  EXPECT_NEAR(10.0 - smoother.S()[0].x(), tau, dt);  // ≈ τ
}

TEST(SkySmoother, SunArrivingOrLeavingRestartsFromTheNewFrame) {
  SkySmoother smoother(10.0);
  smoother.update(0.0, uniform_sky(3, 1.0), std::nullopt);
  smoother.update(1.0, uniform_sky(3, 2.0), std::nullopt);
  EXPECT_FALSE(smoother.restarted());
  EXPECT_LT(smoother.S()[0].x(), 1.2);  // still mostly the old sky
  // The cloud moves off the sun: a new sky at once, not a fade over 10 s.
  smoother.update(2.0, uniform_sky(3, 8.0), Eigen::Vector3d(100, 90, 80));
  EXPECT_TRUE(smoother.restarted());
  EXPECT_EQ(smoother.S()[0].x(), 8.0);
  ASSERT_TRUE(smoother.sun_energy());
  EXPECT_EQ(smoother.sun_energy()->x(), 100.0);
  // While the sun stays, its energy is smoothed like S.
  smoother.update(3.0, uniform_sky(3, 8.0), Eigen::Vector3d(200, 90, 80));
  EXPECT_NEAR(smoother.sun_energy()->x(), 100.0 + 100.0 * (1.0 - std::exp(-0.1)), 1e-9);
  // And it goes again.
  smoother.update(4.0, uniform_sky(3, 1.0), std::nullopt);
  EXPECT_TRUE(smoother.restarted());
  EXPECT_FALSE(smoother.sun_energy());
  EXPECT_EQ(smoother.S()[0].x(), 1.0);
}

TEST(SkySmoother, OffPassesFramesThroughAndTimeRunningBackRestarts) {
  SkySmoother off(0.0);
  off.update(0.0, uniform_sky(2, 1.0), std::nullopt);
  off.update(0.1, uniform_sky(2, 7.0), std::nullopt);
  EXPECT_EQ(off.S()[1].y(), 14.0);

  SkySmoother smoother(1.0);
  smoother.update(5.0, uniform_sky(2, 1.0), std::nullopt);
  smoother.update(5.0, uniform_sky(2, 3.0), std::nullopt);  // same time: nothing elapsed
  EXPECT_FALSE(smoother.restarted());
  EXPECT_EQ(smoother.S()[0].x(), 1.0);
  smoother.update(1.0, uniform_sky(2, 3.0), std::nullopt);  // a recording replayed from its start
  EXPECT_TRUE(smoother.restarted());
  EXPECT_EQ(smoother.S()[0].x(), 3.0);
  smoother.update(2.0, uniform_sky(5, 3.0), std::nullopt);  // another dome
  EXPECT_TRUE(smoother.restarted());
  smoother.reset();
  smoother.update(2.5, uniform_sky(5, 4.0), std::nullopt);
  EXPECT_TRUE(smoother.restarted());
}

TEST(SkySmoother, SmoothsASkyEstimate) {
  SkySmoother smoother(1.0);
  SkyEstimate estimate;
  estimate.luminance.faces.resize(2);
  estimate.luminance.faces[0].rgb = Eigen::Vector3d(1, 1, 1);
  estimate.luminance.faces[1].rgb = Eigen::Vector3d(2, 2, 2);
  smoother.smooth(0.0, estimate);
  estimate.luminance.faces[0].rgb = Eigen::Vector3d(3, 3, 3);
  const SkyEstimate smoothed = smoother.smooth(1.0, estimate);
  EXPECT_NEAR(smoothed.luminance.faces[0].rgb.x(), 1.0 + 2.0 * (1.0 - std::exp(-1.0)), 1e-12);
  EXPECT_EQ(smoothed.luminance.faces[1].rgb.x(), 2.0);
}

TEST(SkySmoother, BadInputsAreInputErrors) {
  EXPECT_THROW(SkySmoother(-1.0), InputError);
  EXPECT_THROW(SkySmoother(std::nan("")), InputError);
  SkySmoother smoother(1.0);
  EXPECT_THROW(smoother.update(std::nan(""), uniform_sky(1, 1.0), std::nullopt), InputError);
  EXPECT_THROW(smoother.update(0.0, uniform_sky(1, std::nan("")), std::nullopt), InputError);
  EXPECT_THROW(smoother.update(0.0, uniform_sky(1, 1.0), Eigen::Vector3d(1, std::nan(""), 1)), InputError);
}

}  // namespace
}  // namespace skylit::sky
