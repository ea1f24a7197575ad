// The One Euro filter: the analytic lag of a first-order low-pass on a ramp, jitter removed from
// a still pose, less lag on a moving one with a higher beta.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "skylit/track/one_euro.hpp"

namespace {

using namespace skylit::track;
constexpr double kPi = std::numbers::pi;
constexpr double kRate = 60;  // Hz, the renderer's

TEST(OneEuro, AlphaOfAFirstOrderLowPass) {
  // α = 1 / (1 + τ/Δt), τ = 1/(2π fc).
  EXPECT_NEAR(one_euro_alpha(1.0, 1.0 / 60), 1.0 / (1.0 + 60.0 / (2 * kPi)), 1e-12);
  EXPECT_GT(one_euro_alpha(10.0, 0.01), one_euro_alpha(1.0, 0.01));  // a higher cutoff follows more
}

// With beta 0 the filter is a fixed low-pass, whose steady lag on a ramp of speed v is v·τ exactly
// (the discrete filter's lag is v·Δt·(1−α)/α = v·τ).
TEST(OneEuro, RampLagIsSpeedTimesTimeConstant) {
  const OneEuroSettings settings{true, 2.0, 0.0, 1.0};
  OneEuroVector filter(settings);
  const Vec3 v(0.3, -0.1, 0.05);  // m/s
  Vec3 out = Vec3::Zero();
  double t = 0;
  for (int k = 0; k < 600; ++k) {
    t = k / kRate;
    out = filter.filter(t, v * t);
  }
  const double tau = 1.0 / (2 * kPi * settings.min_cutoff);
  EXPECT_LT(((v * t - out) - v * tau).norm(), 1e-9);
}

TEST(OneEuro, DisabledPassesThrough) {
  OneEuroVector filter({false, 1.0, 0.0, 1.0});
  filter.filter(0.0, Vec3::Zero());
  EXPECT_EQ(filter.filter(0.1, Vec3(1, 2, 3)), Vec3(1, 2, 3));
}

// Jitter of a still position: the output's spread is a fraction of the input's.
TEST(OneEuro, RemovesJitterOfAStillPose) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);  // 5 mm
  OneEuroVector position({true, 0.5, 5.0, 1.0});
  OneEuroRotation rotation({true, 1.0, 5.0, 1.0});
  const Eigen::Quaterniond still(Eigen::AngleAxisd(0.3, Vec3(1, 2, 3).normalized()));
  double in_sq = 0, out_sq = 0, rin_sq = 0, rout_sq = 0;
  int n = 0;
  for (int k = 0; k < 600; ++k) {
    const double t = k / kRate;
    const Vec3 x(noise(rng), noise(rng), noise(rng));
    const Vec3 y = position.filter(t, x);
    const Vec3 w(noise(rng), noise(rng), noise(rng));  // 5 mrad per axis
    const Eigen::Quaterniond q = still * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
    const Eigen::Quaterniond r = rotation.filter(t, q);
    if (t < 1.0) continue;
    in_sq += x.squaredNorm();
    out_sq += y.squaredNorm();
    rin_sq += std::pow(q.angularDistance(still), 2);
    rout_sq += std::pow(r.angularDistance(still), 2);
    ++n;
  }
  const double position_ratio = std::sqrt(out_sq / in_sq);
  const double rotation_ratio = std::sqrt(rout_sq / rin_sq);
  std::printf("still: jitter kept %.0f%% (position), %.0f%% (rotation)\n", 100 * position_ratio, 100 * rotation_ratio);
  EXPECT_LT(position_ratio, 0.4);
  EXPECT_LT(rotation_ratio, 0.4);
}

// Lag of a head turning at constant speed, and jitter at rest, against beta: a higher beta lags
// less when moving (and keeps more jitter at rest: the trade the setting makes).
TEST(OneEuro, HigherBetaLagsLessWhenMoving) {
  const auto lag_and_jitter = [](double beta) {
    OneEuroRotation moving({true, 1.0, beta, 1.0});
    const Vec3 axis = Vec3(0.2, 1, 0.1).normalized();
    const double speed = 1.5;  // rad/s
    Eigen::Quaterniond out;
    double t = 0;
    for (int k = 0; k < 300; ++k) {
      t = k / kRate;
      out = moving.filter(t, Eigen::Quaterniond(Eigen::AngleAxisd(speed * t, axis)));
    }
    const double lag = out.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(speed * t, axis)));
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.005);
    OneEuroRotation still({true, 1.0, beta, 1.0});
    double sq = 0;
    int n = 0;
    for (int k = 0; k < 600; ++k) {
      const Vec3 w(noise(rng), noise(rng), noise(rng));
      const Eigen::Quaterniond r = still.filter(k / kRate, Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized())));
      if (k > 60) {
        sq += std::pow(r.angularDistance(Eigen::Quaterniond::Identity()), 2);
        ++n;
      }
    }
    return std::pair(lag, std::sqrt(sq / n));
  };
  const auto [lag_low, jitter_low] = lag_and_jitter(0.5);
  const auto [lag_high, jitter_high] = lag_and_jitter(20.0);
  std::printf("1.5 rad/s: lag %.2f° at beta 0.5, %.2f° at beta 20; still jitter %.3f° and %.3f°\n", lag_low * 180 / kPi,
              lag_high * 180 / kPi, jitter_low * 180 / kPi, jitter_high * 180 / kPi);
  EXPECT_LT(lag_high, 0.25 * lag_low);
  EXPECT_GT(jitter_high, jitter_low);
  // Beyond a speed the lag tends to 1/(2π·beta) radians: the cutoff grows with the speed.
  EXPECT_LT(lag_high, 1.0 / (2 * kPi * 20.0) + 1e-3);
}

TEST(OneEuro, PoseFilterResets) {
  OneEuroPose filter({true, 1.0, 0.0, 1.0}, {true, 1.0, 0.0, 1.0});
  Pose a;
  a.timestamp = 0;
  filter.filter(a);
  Pose b;
  b.timestamp = 0.1;
  b.t_site_from_camera = Vec3(1, 0, 0);
  EXPECT_LT(filter.filter(b).t_site_from_camera.x(), 1.0);  // smoothed
  filter.reset();
  b.timestamp = 0.2;
  EXPECT_EQ(filter.filter(b).t_site_from_camera.x(), 1.0);  // starts afresh
}

}  // namespace
