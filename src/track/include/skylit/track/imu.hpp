#pragma once
// The HMD's inertial measurement unit: one interface for a HID device (hid_imu.hpp) and a
// recording replayed from CSV.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace YAML {
class Node;
}

namespace skylit::track {

// Frames and clocks: a sample's gyro and accelerometer are in the IMU frame (right-handed, the
// axes of the profile's `axes` mapping); R_camera_from_imu turns IMU vectors into the HMD camera
// frame (OpenCV's x right, y down, z forward). Timestamps are seconds on the host's steady clock
// (CLOCK_MONOTONIC), the clock the camera frames are stamped with, so IMU samples and camera poses
// can be put on one time line.
struct ImuSample {
  double timestamp = 0;                 // seconds, host steady clock
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, IMU frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s², specific force (+9.81 along "up" at rest)
};

enum class ImuState {
  Waiting,    // open, no sample yet
  Streaming,  // samples arrive
  Gone,       // the device went away (unplugged, read error, recording ended); a device backend
              // keeps trying to reopen it and goes back to Streaming when it returns
  Closed,     // close() was called
};
const char* to_string(ImuState state);

class ImuSource {
 public:
  virtual ~ImuSource() = default;
  // Appends to `out` the samples not read before whose timestamps are ≤ `until`, oldest first,
  // and returns how many. Later samples stay queued for the next call.
  virtual std::size_t read(std::vector<ImuSample>& out, double until) = 0;
  virtual ImuState state() const = 0;
  // The rotation from the IMU frame to the HMD camera frame.
  virtual Eigen::Quaterniond R_camera_from_imu() const = 0;
  // Stops reading and releases the device; state() is Closed after it. Idempotent.
  virtual void close() = 0;
  // "DualShock 4 (USB) 054c:09cc at /dev/hidraw3", "IMU replay head.csv (3000 samples)".
  virtual std::string describe() const = 0;
};

// Seconds on the host's steady clock (the clock of ImuSample::timestamp).
double steady_seconds();

// A recorded IMU stream. read() releases the samples up to `until`; once `until` passes the last
// sample the recording has ended and the state is Gone, as for an unplugged device.
class ReplayImu final : public ImuSource {
 public:
  // Samples with strictly increasing timestamps (std::invalid_argument otherwise); at least one.
  ReplayImu(std::vector<ImuSample> samples, const Eigen::Quaterniond& R_camera_from_imu, std::string name);
  // A CSV read by load_imu_csv.
  static ReplayImu load(const std::filesystem::path& csv, const Eigen::Quaterniond& R_camera_from_imu);

  std::size_t read(std::vector<ImuSample>& out, double until) override;
  ImuState state() const override { return state_; }
  Eigen::Quaterniond R_camera_from_imu() const override { return R_camera_from_imu_; }
  void close() override { state_ = ImuState::Closed; }
  std::string describe() const override;
  const std::vector<ImuSample>& samples() const { return samples_; }

 private:
  std::vector<ImuSample> samples_;
  Eigen::Quaterniond R_camera_from_imu_;
  std::string name_;
  std::size_t next_ = 0;
  ImuState state_ = ImuState::Waiting;
};

// A CSV with the header line `timestamp,gx,gy,gz,ax,ay,az` (seconds, rad/s, m/s², IMU frame).
// InputError naming the file, line and column of a malformed line or of a timestamp that does
// not increase.
std::vector<ImuSample> load_imu_csv(const std::filesystem::path& csv);
// Writes that CSV atomically (a recording for later replay).
void save_imu_csv(const std::filesystem::path& csv, const std::vector<ImuSample>& samples);

// An `imu:` node of a config file:
//
//   imu:
//     kind: hid                        # a HID device decoded by a profile
//     profile: imu/dualshock4_usb.yaml # relative to the config file's folder
//     path: /dev/hidraw3               # optional: this device when several match
//     R_camera_from_imu: [1, 0, 0, 0]  # optional: overrides the profile's (qw, qx, qy, qz)
//
//   imu:
//     kind: replay
//     csv: head_imu.csv                # timestamp,gx,gy,gz,ax,ay,az
//     R_camera_from_imu: [1, 0, 0, 0]  # optional, default identity
struct ImuConfig {
  enum class Kind { Hid, Replay };
  Kind kind = Kind::Hid;
  std::filesystem::path profile;  // Kind::Hid
  std::string path;               // Kind::Hid, optional
  std::filesystem::path csv;      // Kind::Replay
  std::optional<Eigen::Quaterniond> R_camera_from_imu;
};

// InputError naming the file, line, column and field for anything missing, unknown or wrong.
// `root`: the folder its paths must lie in (the including config's root); empty, the file's folder.
ImuConfig parse_imu_config(const YAML::Node& node, const std::filesystem::path& file,
                           const std::filesystem::path& root = {});
// A HID device (InputError listing the devices present when none matches) or a replay.
std::unique_ptr<ImuSource> open_imu(const ImuConfig& config);

}  // namespace skylit::track
