// Pose fusion on a synthetic head with a known trajectory: a gyro with noise and bias, camera
// poses at 30 Hz that arrive 40 ms late with noise, a gap of a second without tags, prediction to
// the display time, an IMU that disappears, tracking lost and regained.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numeric>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/track/fusion.hpp"
#include "synthetic_head.hpp"

namespace {

using namespace skylit::track;
using synthetic::degrees;

constexpr double kImuLatency = 0.002;  // s from a sample's time to its arrival
constexpr double kRenderRate = 60;     // Hz

struct Observation {
  double now = 0;
  double display = 0;
  FusedPose fused;
};

// Runs the fusion as the live service would: every millisecond the IMU samples that have arrived
// and the camera poses that have arrived are added; at 60 Hz the renderer asks for the pose at
// now + lead.
std::vector<Observation> simulate(PoseFusion& fusion, ImuSource* imu, const std::vector<synthetic::TimedPose>& poses, double t0,
                                  double t1, double lead) {
  std::vector<Observation> out;
  std::size_t next_pose = 0;
  double next_render = t0;
  for (long tick = 0;; ++tick) {
    const double now = t0 + 1e-3 * static_cast<double>(tick);
    if (now >= t1) break;
    if (imu != nullptr) fusion.add_imu_from(*imu, now - kImuLatency);
    while (next_pose < poses.size() && poses[next_pose].arrival <= now) fusion.add_camera_pose(poses[next_pose++].pose);
    if (now >= next_render) {
      next_render += 1.0 / kRenderRate;
      out.push_back({now, now + lead, fusion.estimate(now + lead)});
    }
  }
  return out;
}

double rotation_error(const synthetic::Head& head, const Observation& o) {
  return head.rotation(o.display).angularDistance(o.fused.pose.R_site_from_camera);
}
double position_error(const synthetic::Head& head, const Observation& o) {
  return (head.position(o.display) - o.fused.pose.t_site_from_camera).norm();
}

template <typename Value>
double max_over(const std::vector<Observation>& run, double from, double to, Value value) {
  double m = 0;
  for (const auto& o : run) {
    if (o.now >= from && o.now < to) m = std::max(m, value(o));
  }
  return m;
}

template <typename Value>
double rms_over(const std::vector<Observation>& run, double from, double to, Value value) {
  double sum = 0;
  int n = 0;
  for (const auto& o : run) {
    if (o.now >= from && o.now < to) {
      sum += value(o) * value(o);
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

FusionSettings settings_for(const synthetic::ImuModel& model) {
  FusionSettings s;
  s.R_camera_from_imu = model.R_camera_from_imu;
  return s;
}

// The headline case: replayed IMU plus camera poses with a one-second gap in the tags.
TEST(PoseFusion, ContinuousThroughAGapInTheTagsWithTheBiasEstimated) {
  const synthetic::Head head;
  const synthetic::ImuModel imu_model;
  synthetic::CameraModel camera;
  camera.gap_start = 6.0;
  camera.gap_end = 7.0;
  ReplayImu imu(synthetic::imu_samples(head, imu_model, 0.0, 10.0, 1), imu_model.R_camera_from_imu, "synthetic");
  const auto poses = synthetic::camera_poses(head, camera, 0.0, 10.0, 2);
  PoseFusion fusion(settings_for(imu_model));
  const auto run = simulate(fusion, &imu, poses, 0.0, 10.0, 0.0);

  const auto rot = [&](const Observation& o) { return degrees(rotation_error(head, o)); };
  const auto pos = [&](const Observation& o) { return position_error(head, o); };
  const double before_rms = rms_over(run, 2.0, 6.0, rot);
  const double gap_max = max_over(run, 6.0, 7.0, rot);
  const double gap_rms = rms_over(run, 6.0, 7.0, rot);
  const double after_max = max_over(run, 7.5, 10.0, rot);
  std::printf("rotation error: tracking rms %.3f°, gap rms %.3f° max %.3f°, after max %.3f°\n", before_rms, gap_rms, gap_max, after_max);
  // Head turning at up to 150 °/s, camera noise 0.3° per axis: the gyro carries the pose.
  EXPECT_LT(before_rms, 0.3);
  EXPECT_LT(gap_max, 0.6);  // a second on the gyro alone, bias estimated
  EXPECT_LT(after_max, 0.6);

  // The bias, estimated in the IMU frame, within 0.003 rad/s of the simulated one.
  const FusedPose at6 = std::find_if(run.begin(), run.end(), [](const Observation& o) { return o.now >= 5.99; })->fused;
  std::printf("bias true (%.4f %.4f %.4f) estimated (%.4f %.4f %.4f) rad/s\n", imu_model.bias.x(), imu_model.bias.y(),
              imu_model.bias.z(), at6.gyro_bias.x(), at6.gyro_bias.y(), at6.gyro_bias.z());
  EXPECT_LT((at6.gyro_bias - imu_model.bias).norm(), 0.003);

  // States: tracking, coasting through the gap (confidence falls, never to 0: the building stays),
  // tracking again; never lost.
  for (const auto& o : run) {
    if (o.now < 0.5) continue;
    const bool in_gap = o.now >= 6.0 + camera.latency + 0.21 && o.now < 7.0 + camera.latency;
    if (in_gap) {
      EXPECT_EQ(o.fused.state, TrackingState::Coasting) << o.now;
      EXPECT_GT(o.fused.confidence, 0.2) << o.now;
      EXPECT_LT(o.fused.confidence, 1.0) << o.now;
    } else if (o.now > 7.0 + camera.latency + 0.01 || o.now < 6.0) {
      EXPECT_EQ(o.fused.state, TrackingState::Tracking) << o.now;
    }
    EXPECT_EQ(o.fused.imu, ImuLink::Live);
  }
  // Position: held through the gap (the gyro knows nothing of it), so off by at most what the
  // head moved since the last pose, plus 2 cm; within 1 cm while tracking.
  EXPECT_LT(rms_over(run, 2.0, 6.0, pos), 0.01);
  for (const auto& o : run) {
    if (o.now < 6.1 || o.now >= 7.0) continue;
    const double moved = (head.position(o.display) - head.position(6.0 - 1.0 / 30)).norm();
    EXPECT_LT(position_error(head, o), moved + 0.02) << o.now;
  }
  // Continuous: no step between renders bigger than the head's own motion plus 0.5°, also when
  // the tags come back.
  for (std::size_t i = 1; i < run.size(); ++i) {
    if (run[i].now < 0.5) continue;  // the first poses set it
    const double step = run[i].fused.pose.R_site_from_camera.angularDistance(run[i - 1].fused.pose.R_site_from_camera);
    const double true_step = head.rotation(run[i].display).angularDistance(head.rotation(run[i - 1].display));
    EXPECT_LT(degrees(step), degrees(true_step) + 0.5) << run[i].now;
  }
  EXPECT_EQ(fusion.counters().late_camera_poses, 0u);
}

// The bias is what is estimated, not hidden by the camera: with the camera poses gone, a gyro
// without bias correction would drift by |bias| · t.
TEST(PoseFusion, BiasEstimateBeatsRawGyroInTheGap) {
  const synthetic::Head head;
  synthetic::ImuModel imu_model;
  imu_model.bias = Eigen::Vector3d(0.05, -0.04, 0.03);  // 3.9 °/s: a badly calibrated gyro
  synthetic::CameraModel camera;
  camera.gap_start = 5.0;
  camera.gap_end = 6.0;
  ReplayImu imu(synthetic::imu_samples(head, imu_model, 0.0, 6.0, 3), imu_model.R_camera_from_imu, "synthetic");
  PoseFusion fusion(settings_for(imu_model));
  const auto run = simulate(fusion, &imu, synthetic::camera_poses(head, camera, 0.0, 6.0, 4), 0.0, 6.0, 0.0);
  const double gap_end_error = degrees(rotation_error(head, run.back()));
  const double uncorrected = degrees(imu_model.bias.norm() * (run.back().display - (5.0 - 1.0 / 30)));
  std::printf("after 1 s without tags: %.3f° (an uncorrected bias would give %.2f°)\n", gap_end_error, uncorrected);
  EXPECT_LT(gap_end_error, 0.1 * uncorrected);
}

// Predicting 20 ms ahead beats showing the newest estimate on a turning head.
TEST(PoseFusion, PredictionAheadBeatsNoPrediction) {
  synthetic::Head head;
  head.yaw = {{0.9, 0.4, 0.0}};  // up to 2.3 rad/s (130 °/s)
  const synthetic::ImuModel imu_model;
  const synthetic::CameraModel camera;
  FusionSettings settings = settings_for(imu_model);
  settings.position_filter.enabled = false;
  settings.rotation_filter.enabled = false;
  const double lead = 0.020;

  ReplayImu imu_a(synthetic::imu_samples(head, imu_model, 0.0, 6.0, 5), imu_model.R_camera_from_imu, "a");
  PoseFusion predicted(settings);
  const auto ahead = simulate(predicted, &imu_a, synthetic::camera_poses(head, camera, 0.0, 6.0, 6), 0.0, 6.0, lead);
  ReplayImu imu_b(synthetic::imu_samples(head, imu_model, 0.0, 6.0, 5), imu_model.R_camera_from_imu, "b");
  PoseFusion newest(settings);
  auto stale = simulate(newest, &imu_b, synthetic::camera_poses(head, camera, 0.0, 6.0, 6), 0.0, 6.0, 0.0);
  for (auto& o : stale) o.display += lead;  // shown 20 ms later than it was computed for

  const auto rot = [&](const Observation& o) { return degrees(rotation_error(head, o)); };
  const double with = rms_over(ahead, 1.0, 6.0, rot);
  const double without = rms_over(stale, 1.0, 6.0, rot);
  std::printf("20 ms ahead: rms %.3f° predicted, %.3f° not predicted\n", with, without);
  EXPECT_LT(with, 0.25 * without);
  EXPECT_LT(with, 0.5);
}

// Unplugged mid-replay: the fusion falls back to the camera poses and says so.
TEST(PoseFusion, ImuThatDisappearsFallsBackToCameraOnlyFlagged) {
  const synthetic::Head head;
  const synthetic::ImuModel imu_model;
  const synthetic::CameraModel camera;
  ReplayImu imu(synthetic::imu_samples(head, imu_model, 0.0, 4.0, 7), imu_model.R_camera_from_imu, "unplugged at 4 s");
  PoseFusion fusion(settings_for(imu_model));
  const auto run = simulate(fusion, &imu, synthetic::camera_poses(head, camera, 0.0, 8.0, 8), 0.0, 8.0, 0.0);
  EXPECT_EQ(imu.state(), ImuState::Gone);
  const auto rot = [&](const Observation& o) { return degrees(rotation_error(head, o)); };
  for (const auto& o : run) {
    if (o.now > 1.0 && o.now < 4.0) {
      EXPECT_EQ(o.fused.imu, ImuLink::Live) << o.now;
    }
    if (o.now > 4.0 + kImuLatency + 0.11) {
      EXPECT_EQ(o.fused.imu, ImuLink::Gone) << o.now;
      EXPECT_EQ(o.fused.state, TrackingState::Tracking) << o.now;
      EXPECT_DOUBLE_EQ(o.fused.confidence, 1.0) << o.now;
    }
  }
  const double fused_rms = rms_over(run, 1.0, 4.0, rot);
  const double camera_only_rms = rms_over(run, 4.5, 8.0, rot);
  std::printf("rotation rms: %.3f° with the gyro, %.3f° on camera poses alone (40 ms late, extrapolated)\n", fused_rms,
              camera_only_rms);
  EXPECT_LT(camera_only_rms, 3.0);  // a continuing pose, rougher than with the gyro
  EXPECT_GT(camera_only_rms, fused_rms);
  // Plugged in again: live again, and fused as before within a second.
  ReplayImu back(synthetic::imu_samples(head, imu_model, 8.0, 12.0, 9), imu_model.R_camera_from_imu, "plugged in at 8 s");
  const auto again = simulate(fusion, &back, synthetic::camera_poses(head, camera, 8.0, 12.0, 10), 8.0, 12.0, 0.0);
  EXPECT_EQ(again.back().fused.imu, ImuLink::Live);
  EXPECT_LT(rms_over(again, 9.0, 12.0, rot), 0.5);
}

// Without tags for longer than lost_after: lost (no pose, confidence 0); when they come back the
// confidence rises from 0 over reacquire_fade, so the building fades in instead of jumping.
TEST(PoseFusion, LostAfterTheLimitAndFadesBackIn) {
  const synthetic::Head head;
  const synthetic::ImuModel imu_model;
  synthetic::CameraModel camera;
  camera.gap_start = 3.0;
  camera.gap_end = 6.0;
  FusionSettings settings = settings_for(imu_model);
  settings.position_filter.enabled = false;  // to see the held position exactly
  ReplayImu imu(synthetic::imu_samples(head, imu_model, 0.0, 8.0, 11), imu_model.R_camera_from_imu, "synthetic");
  PoseFusion fusion(settings);
  const auto run = simulate(fusion, &imu, synthetic::camera_poses(head, camera, 0.0, 8.0, 12), 0.0, 8.0, 0.0);

  const double last_pose = 3.0 - 1.0 / 30;
  double previous_confidence = 1.0;
  Eigen::Vector3d held = Eigen::Vector3d::Constant(NAN);
  for (const auto& o : run) {
    const double age = o.display - last_pose;
    if (o.now < 3.0 || o.now >= 6.0) continue;
    if (age > settings.camera_timeout + 0.01 && age < settings.lost_after - 0.01) {
      EXPECT_EQ(o.fused.state, TrackingState::Coasting) << o.now;
      EXPECT_LE(o.fused.confidence, previous_confidence) << o.now;
      previous_confidence = o.fused.confidence;
      if (age > settings.max_prediction + 0.05) {
        if (std::isnan(held.x())) held = o.fused.pose.t_site_from_camera;
        EXPECT_EQ(o.fused.pose.t_site_from_camera, held) << "position held at " << o.now;
      }
    }
    if (age > settings.lost_after + 0.01) {
      EXPECT_EQ(o.fused.state, TrackingState::Lost) << o.now;
      EXPECT_EQ(o.fused.confidence, 0.0);
    }
  }
  // Lost: no pose (a fusion that has heard nothing from the camera since 3 s).
  PoseFusion alone(settings);
  ReplayImu imu_alone(synthetic::imu_samples(head, imu_model, 0.0, 5.0, 11), imu_model.R_camera_from_imu, "synthetic");
  simulate(alone, &imu_alone, synthetic::camera_poses(head, camera, 0.0, 3.0, 12), 0.0, 5.0, 0.0);
  EXPECT_EQ(alone.estimate(5.0).state, TrackingState::Lost);
  EXPECT_FALSE(alone.pose_at(5.0).has_value());
  // Back at 6.0 (first pose arrives 40 ms later): the confidence ramps 0 → 1 over 0.3 s.
  const auto observation = [&](double t) {
    return *std::find_if(run.begin(), run.end(), [t](const Observation& o) { return o.now >= t; });
  };
  const auto at = [&](double t) { return observation(t).fused; };
  const double back = 6.0 + camera.latency;
  EXPECT_EQ(at(back + 0.02).state, TrackingState::Tracking);
  EXPECT_LT(at(back + 0.02).confidence, 0.35);
  EXPECT_GT(at(back + 0.2).confidence, 0.4);
  EXPECT_DOUBLE_EQ(at(back + 0.4).confidence, 1.0);
  EXPECT_LT(degrees(rotation_error(head, observation(back + 0.4))), 0.5);
}

// Camera poses arriving before the IMU samples that precede them, and IMU samples out of order,
// give the same filter as everything in time order (the history is integrated again).
TEST(PoseFusion, OrderOfArrivalDoesNotChangeTheResult) {
  const synthetic::Head head;
  const synthetic::ImuModel imu_model;
  synthetic::CameraModel camera;
  camera.latency = 0;
  const auto samples = synthetic::imu_samples(head, imu_model, 0.0, 2.0, 13);
  const auto poses = synthetic::camera_poses(head, camera, 0.0, 2.0, 14);
  FusionSettings settings = settings_for(imu_model);
  settings.rotation_filter.enabled = false;
  settings.position_filter.enabled = false;

  PoseFusion in_order(settings);
  PoseFusion shuffled(settings);
  const auto feed_in_order = [&](PoseFusion& fusion, std::size_t from, std::size_t to, std::size_t& p) {
    for (std::size_t i = from; i < to; ++i) {
      while (p < poses.size() && poses[p].pose.timestamp <= samples[i].timestamp) fusion.add_camera_pose(poses[p++].pose);
      fusion.add_imu(samples[i]);
    }
  };
  std::size_t p = 0;
  feed_in_order(in_order, 0, samples.size(), p);
  // The same start (the first 0.1 s), then each camera pose as soon as the sample 20 ms before
  // it is in, and the samples swapped in pairs.
  const std::size_t start = 50;
  std::size_t q = 0;
  feed_in_order(shuffled, 0, start, q);
  for (std::size_t i = start; i < samples.size(); i += 2) {
    if (i + 1 < samples.size()) shuffled.add_imu(samples[i + 1]);
    shuffled.add_imu(samples[i]);
    const double newest = samples[std::min(i + 1, samples.size() - 1)].timestamp;
    while (q < poses.size() && poses[q].pose.timestamp <= newest + 0.020) shuffled.add_camera_pose(poses[q++].pose);
  }
  const double t = samples.back().timestamp;
  const FusedPose a = in_order.estimate(t);
  const FusedPose b = shuffled.estimate(t);
  EXPECT_LT(a.pose.R_site_from_camera.angularDistance(b.pose.R_site_from_camera), 1e-9);
  EXPECT_LT((a.gyro_bias - b.gyro_bias).norm(), 1e-9);
  EXPECT_EQ(shuffled.counters().camera_poses, poses.size());
}

TEST(PoseFusion, TooLateCameraPosesAreCountedAndDropped) {
  const synthetic::Head head;
  const synthetic::ImuModel imu_model;
  PoseFusion fusion(settings_for(imu_model));
  for (const auto& s : synthetic::imu_samples(head, imu_model, 0.0, 2.0, 15)) fusion.add_imu(s);
  fusion.add_camera_pose(head.pose(1.0));  // 1 s old, the history holds 0.5 s
  EXPECT_EQ(fusion.counters().late_camera_poses, 1u);
  EXPECT_FALSE(fusion.pose_at(2.0).has_value());  // still initializing: no pose taken
  fusion.add_camera_pose(head.pose(1.9));
  EXPECT_TRUE(fusion.pose_at(2.0).has_value());
}

TEST(PoseFusion, CameraOnlyWithoutAnyImu) {
  const synthetic::Head head;
  synthetic::CameraModel camera;
  camera.latency = 0;
  PoseFusion fusion;
  EXPECT_FALSE(fusion.pose_at(0.0).has_value());
  EXPECT_EQ(fusion.estimate(0.0).state, TrackingState::Initializing);
  const auto run = simulate(fusion, nullptr, synthetic::camera_poses(head, camera, 0.0, 3.0, 16), 0.0, 3.0, 0.0);
  EXPECT_EQ(run.back().fused.imu, ImuLink::None);
  EXPECT_EQ(run.back().fused.state, TrackingState::Tracking);
  EXPECT_LT(rms_over(run, 1.0, 3.0, [&](const Observation& o) { return degrees(rotation_error(head, o)); }), 3.0);
  // Without the gyro the pose is held for hold_without_imu only.
  EXPECT_EQ(fusion.estimate(3.0 + 0.4).state, TrackingState::Coasting);
  EXPECT_EQ(fusion.estimate(3.0 + 0.6).state, TrackingState::Lost);
}

TEST(FusionSettings, ParsedFromYaml) {
  const std::string yaml =
      "fusion:\n  max_prediction: 0.05\n  lost_after: 2.0\n  rotation_filter: {min_cutoff: 0.5, beta: 10}\n"
      "  position_filter: {enabled: false}\n";
  const FusionSettings s = parse_fusion_settings(YAML::Load(yaml)["fusion"], "site.yaml");
  EXPECT_DOUBLE_EQ(s.max_prediction, 0.05);
  EXPECT_DOUBLE_EQ(s.lost_after, 2.0);
  EXPECT_DOUBLE_EQ(s.rotation_filter.min_cutoff, 0.5);
  EXPECT_DOUBLE_EQ(s.rotation_filter.beta, 10.0);
  EXPECT_FALSE(s.position_filter.enabled);
  EXPECT_DOUBLE_EQ(s.camera_timeout, FusionSettings{}.camera_timeout);

  const auto error = [](const std::string& text) {
    try {
      parse_fusion_settings(YAML::Load(text)["fusion"], "site.yaml");
    } catch (const skylit::InputError& e) {
      return std::string(e.what());
    }
    return std::string("(no InputError)");
  };
  EXPECT_NE(error("fusion:\n  lost_afte: 2\n").find("did you mean 'lost_after'"), std::string::npos);
  EXPECT_NE(error("fusion:\n  lost_after: 0.1\n").find("fusion.lost_after"), std::string::npos);
  EXPECT_NE(error("fusion:\n  rotation_filter: {beta: -1}\n").find("fusion.rotation_filter.beta"), std::string::npos);
  EXPECT_NE(error("fusion:\n  camera_timeout: 0\n").find("site.yaml:2"), std::string::npos);
}

}  // namespace
