#pragma once
// Head pose from the HMD's gyro and the marker tracker's camera poses: gyro integration between
// camera poses, corrected by them, predicted to the display time, smoothed by a One Euro filter,
// with a tracking state and a confidence the renderer fades the building with.
#include <cstddef>
#include <deque>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "skylit/track/imu.hpp"
#include "skylit/track/one_euro.hpp"
#include "skylit/track/pose.hpp"

namespace YAML {
class Node;
}

namespace skylit::track {

struct FusionSettings {
  // Gyro model.
  double gyro_noise = 0.003;          // rad/s/√Hz: white noise density (BMI055: 0.014 °/s/√Hz ≈ 2.4e-4)
  double gyro_bias_walk = 2e-4;       // rad/s/√s: how fast the bias may wander
  double initial_bias_sigma = 0.05;   // rad/s: the bias before any camera pose
  // Camera pose noise (one standard deviation per pose, per axis).
  double camera_rotation_sigma = 0.01;  // rad
  double camera_position_sigma = 0.01;  // m
  double head_acceleration = 0.5;       // m/s²: the position filter's process noise (higher follows
                                        // faster moves, extrapolates more noise)
  // Time.
  double history = 0.5;           // s: camera poses up to this late are applied at their time
  double max_prediction = 0.1;    // s: the furthest ahead of the data a pose is extrapolated
  double camera_timeout = 0.2;    // s: Tracking while a camera pose is this recent
  double lost_after = 1.5;        // s without camera poses, gyro live: Lost
  double hold_without_imu = 0.5;  // s without camera poses and no gyro: Lost
  double imu_timeout = 0.1;       // s without IMU samples: the IMU is Gone
  double reacquire_fade = 0.3;    // s for the confidence to rise from 0 after Lost
  // The IMU's mounting (from the ImuSource or the profile).
  Eigen::Quaterniond R_camera_from_imu = Eigen::Quaterniond::Identity();
  // Jitter filters on the output (beta: Hz per m/s and Hz per rad/s). With a live gyro the
  // rotation is left unfiltered unless filter_rotation_with_gyro: the Kalman filter already
  // weighs the camera noise, and a low-pass on the gyro's smooth output only adds lag (on the
  // test head, 0.13° rms becomes 0.44° at beta 20).
  OneEuroSettings position_filter{true, 0.5, 5.0, 1.0};
  OneEuroSettings rotation_filter{true, 1.0, 5.0, 1.0};
  bool filter_rotation_with_gyro = false;
};

// States (all at the requested time t):
//   Initializing  no camera pose yet: pose_at() gives nullopt
//   Tracking      a camera pose within camera_timeout
//   Coasting      none for longer: with a live gyro the orientation continues and the position is
//                 held, the confidence falls to 0 at lost_after; without the gyro the pose is
//                 held and the confidence falls to 0 at hold_without_imu
//   Lost          beyond: pose_at() gives nullopt; the next camera pose starts again, the
//                 confidence rising from 0 over reacquire_fade (no jump of the building)
// The IMU is Live (a sample within imu_timeout of t), Gone (samples came, then stopped: the
// fusion falls back to the camera poses alone) or None (no sample ever).
enum class TrackingState { Initializing, Tracking, Coasting, Lost };
enum class ImuLink { None, Live, Gone };
const char* to_string(TrackingState state);
const char* to_string(ImuLink link);

struct FusedPose {
  Pose pose;                 // at the requested time (predicted when ahead of the data)
  TrackingState state = TrackingState::Initializing;
  ImuLink imu = ImuLink::None;
  double confidence = 0;     // [0, 1]: the renderer's opacity for the building
  double camera_age = 0;     // s since the last camera pose (infinity before the first)
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // rad/s, IMU frame
  double rotation_sigma = 0;  // rad: the filter's 1σ orientation uncertainty
};

struct FusionCounters {
  std::size_t imu_samples = 0;
  std::size_t camera_poses = 0;
  std::size_t late_camera_poses = 0;       // older than `history`, dropped
  std::size_t out_of_order_camera_poses = 0;  // older than the newest: they correct the orientation only
  std::size_t out_of_order_imu_samples = 0;   // older than the history, dropped
};

// Orientation: an error-state Kalman filter over (rotation error, gyro bias), 6 states. Why not
// a complementary filter: the camera poses come at 30 Hz, late and sometimes not at all, and a
// complementary filter with a fixed gain either lets the gyro bias drift show during a gap or
// passes camera noise through; the Kalman gain weighs each camera pose by how far the gyro has
// drifted since the last one, and estimating the bias keeps a gap of a second or two within a
// fraction of a degree. Late camera poses are applied at their own time: the filter keeps a
// short history of states and re-integrates the gyro samples that came after.
//
// Position: a constant-velocity Kalman filter per axis on the camera positions (the gyro tells
// nothing of position; double-integrating the accelerometer drifts by metres within a second).
// Between camera poses and for prediction it is extrapolated by its velocity, for at most
// max_prediction; without camera poses it is held.
//
// Thread safety: every member may be called from any thread (one mutex), so an IMU thread, the
// tracker and the renderer can share one fusion.
class PoseFusion final : public PoseSource {
 public:
  explicit PoseFusion(const FusionSettings& settings = {});

  // A gyro/accelerometer sample (IMU frame, host clock). Samples may come a little out of order
  // (within the history); each costs one integration step, more when it lands in the past.
  void add_imu(const ImuSample& sample);
  // Reads an IMU source up to `until` and adds its samples, turned by the source's own
  // R_camera_from_imu (add_imu uses the settings'); returns how many.
  std::size_t add_imu_from(ImuSource& source, double until);
  // A camera pose from the marker tracker, stamped with its frame's time; may arrive after IMU
  // samples that are later than it.
  void add_camera_pose(const Pose& pose);

  // The fused pose at `timestamp` (usually the display time: predicted from the newest data),
  // jitter-filtered; nullopt while Initializing or Lost. Times that do not increase skip the
  // jitter filter's update.
  std::optional<Pose> pose_at(double timestamp) override;
  // The same with state, confidence and the gyro bias.
  FusedPose estimate(double timestamp);
  std::string describe() const override;

  FusionCounters counters() const;
  const FusionSettings& settings() const { return settings_; }

 private:
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  // The orientation filter after a step: what a late camera pose rolls back to.
  struct Entry {
    double t = 0;
    Eigen::Vector3d omega = Eigen::Vector3d::Zero();  // measured rate, camera frame, rad/s
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // R_site_from_camera
    Eigen::Vector3d bias = Eigen::Vector3d::Zero();   // camera frame
    Mat6 P = Mat6::Zero();
    bool sample = false;  // an IMU sample is at t
    bool camera = false;  // a camera update happened at t (re-applied when integrating again)
    Eigen::Quaterniond measured = Eigen::Quaterniond::Identity();  // its camera orientation
  };
  struct PositionFilter {
    bool started = false;
    double t = 0;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    Eigen::Matrix2d P = Eigen::Matrix2d::Zero();  // the same for each axis
  };

  void propagate(const Entry& from, Entry& to) const;
  void camera_update(Entry& entry, const Eigen::Quaterniond& measured) const;
  void recompute_from(std::size_t first);
  std::size_t refresh_camera_rates(std::size_t sample);
  static Eigen::Vector3d interpolate_rate(const Entry& before, const Entry& after, double t);
  void trim_history();
  void reseed_orientation(double t);
  void update_position(const Pose& pose);
  FusedPose raw_estimate(double t) const;
  ImuLink imu_link(double t) const;

  FusionSettings settings_;
  mutable std::mutex mutex_;
  std::deque<Entry> history_;  // increasing t
  double newest_imu_ = -1e300;
  bool imu_seen_ = false;
  // The orientation filter's bias and its covariance survive an IMU outage.
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d bias_P_;
  std::optional<Pose> last_camera_;
  std::optional<Pose> previous_camera_;
  double last_applied_camera_ = -1e300;
  PositionFilter position_;
  // Confidence after a loss; the jitter filter starts afresh then.
  double reacquired_at_ = 0;
  bool reset_jitter_ = false;
  OneEuroPose jitter_;
  double last_output_t_ = -1e300;
  Pose last_output_;
  FusionCounters counters_;
};

// A `fusion:` node of a config file; every key optional (the defaults above). InputError naming
// the file, line, column and field for an unknown key or a value out of range.
FusionSettings parse_fusion_settings(const YAML::Node& node, const std::filesystem::path& file);

}  // namespace skylit::track
