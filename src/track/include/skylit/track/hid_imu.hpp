#pragma once
// IMUs that speak USB HID: a generic input-report decoder configured in YAML (config/imu/*.yaml,
// described in docs/imu.md), the mapping of the device's clock onto the host's, and the hidapi
// backend (enumerate, open, read in its own thread, reopen after an unplug). hidapi's types stay
// in the source file.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "skylit/track/imu.hpp"

namespace YAML {
class Node;
}

namespace skylit::track {

enum class HidFieldType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32 };
enum class Endian { Little, Big };

// One number in a report: `offset` counts bytes from the report's first byte (the report id when
// the device numbers its reports, as hidapi returns it).
struct HidField {
  std::size_t offset = 0;
  HidFieldType type = HidFieldType::Int16;
  Endian endian = Endian::Little;
  double scale = 1;  // units per count: rad/s, m/s² or seconds
};
std::size_t field_size(HidFieldType type);
// The raw count at field's offset (no scale); the report must hold offset + size bytes.
double read_raw(std::span<const std::uint8_t> report, const HidField& field);

struct HidImuProfile {
  std::string name;                       // "Sony DualShock 4 (USB)"
  std::uint16_t vendor_id = 0;
  std::vector<std::uint16_t> product_ids;  // at least one
  // The first byte of the input reports that carry the IMU; reports with another first byte are
  // skipped. None: the device does not number its reports.
  std::optional<std::uint8_t> report_id;
  std::size_t report_size = 0;            // bytes read per report; covers every field
  // Device time (scale: seconds per count). Integer counters wrap and are unwrapped. None: the
  // host's receive time stamps the sample.
  std::optional<HidField> timestamp;
  std::array<HidField, 3> gyro{};   // the device's x, y, z; rad/s per count
  std::array<HidField, 3> accel{};  // m/s² per count
  // IMU axes from device axes (a signed permutation, from `axes: [x, -z, y]`): v_imu = M · v_device.
  Eigen::Matrix3d imu_from_device = Eigen::Matrix3d::Identity();
  Eigen::Quaterniond R_camera_from_imu = Eigen::Quaterniond::Identity();
  std::filesystem::path file;  // where it was read from, for messages

  bool matches(std::uint16_t vendor, std::uint16_t product) const;
};

// InputError naming the file, line, column and field for anything missing, unknown or wrong
// (a field past report_size, a non-permutation axis mapping, a rotation that is not unit).
HidImuProfile parse_hid_imu_profile(const YAML::Node& root, const std::filesystem::path& file);
HidImuProfile load_hid_imu_profile(const std::filesystem::path& file);
// Every *.yaml of a folder (config/imu), sorted by file name.
std::vector<HidImuProfile> load_hid_imu_profiles(const std::filesystem::path& folder);

// Maps device time onto the host clock. The host stamps each report when it arrives, which is
// the device time plus a constant offset plus a delay that is never negative (USB polling,
// scheduling). The least-delayed report shows the offset best, so the estimate follows the
// minimum of (receive − device); it may creep up by `max_drift` seconds per second so that a
// device clock slower than the host's is followed too. Host jitter does not reach the samples.
class DeviceClock {
 public:
  explicit DeviceClock(double max_drift = 2e-4);
  double to_host(double device_seconds, double receive_seconds);
  void reset() { started_ = false; }

 private:
  double max_drift_;
  bool started_ = false;
  double offset_ = 0;
  double last_device_ = 0;
};

enum class DecodeStatus { Ok, WrongReportId, TooShort };

// Turns input reports into samples: fields read and scaled, axes mapped to the IMU frame,
// the device's counter unwrapped and put on the host clock. The sample stays in the IMU frame
// (the profile's R_camera_from_imu is for the fusion).
class HidReportDecoder {
 public:
  explicit HidReportDecoder(HidImuProfile profile);
  // `report` as hidapi returns it; `receive_seconds` the host time it arrived.
  DecodeStatus decode(std::span<const std::uint8_t> report, double receive_seconds, ImuSample& sample);
  // The device was reopened: its counter starts afresh.
  void reset();
  const HidImuProfile& profile() const { return profile_; }

 private:
  double device_seconds(std::span<const std::uint8_t> report, double receive_seconds);

  HidImuProfile profile_;
  DeviceClock clock_;
  bool have_counter_ = false;
  std::uint64_t last_count_ = 0;
  double last_receive_ = 0;
  double device_time_ = 0;
};

// A HID device present on the system.
struct HidDeviceInfo {
  std::uint16_t vendor_id = 0;
  std::uint16_t product_id = 0;
  std::string path;          // hidapi's path (/dev/hidrawN with the hidraw backend)
  std::string manufacturer;
  std::string product;
  std::string serial;
  int interface_number = -1;
  std::string profile;       // the name of the first matching profile, empty when none
  std::filesystem::path profile_file;
};
// All HID devices, each with the profile that matches it. An empty list (not an error) when
// there are none or hidapi cannot enumerate on this system.
std::vector<HidDeviceInfo> enumerate_hid_devices(std::span<const HidImuProfile> profiles = {});

struct HidImuOptions {
  std::string path;              // open this device; empty: the first that matches the profile
  double read_timeout = 0.1;     // seconds one read waits, so stopping is prompt
  double reconnect_first = 0.1;  // seconds before the first reopen attempt after an unplug
  double reconnect_max = 2.0;    // the wait doubles up to this
  std::size_t queue_capacity = 8192;  // samples kept for read(); the oldest are dropped beyond
};

// How the reader reaches HID devices: hidapi (hidapi_transport) in use, a scripted device in the
// tests of the reader's thread (reconnection after an unplug).
class HidTransport {
 public:
  virtual ~HidTransport() = default;
  virtual std::vector<HidDeviceInfo> enumerate() = 0;
  // Opens the device at `path`, closing any open one; false when it cannot (see last_error).
  virtual bool open(const std::string& path) = 0;
  // One input report into `buffer`: its length, 0 when none came within `timeout_ms`, < 0 when
  // the device is gone.
  virtual int read(std::span<std::uint8_t> buffer, int timeout_ms) = 0;
  virtual void close() = 0;
  virtual std::string last_error() = 0;
};
std::unique_ptr<HidTransport> hidapi_transport();

// Opens the first device the profile matches (or options.path) and reads it in a thread of its
// own. InputError naming the profile file when no device matches, listing the HID devices that
// are there, or when the device cannot be opened (permissions: a udev rule is the fix).
// Unplugged later: state() becomes Gone and the thread reopens it with a doubling backoff.
std::unique_ptr<ImuSource> open_hid_imu(const HidImuProfile& profile, const HidImuOptions& options = {});
// The same over another transport.
std::unique_ptr<ImuSource> open_hid_imu(const HidImuProfile& profile, const HidImuOptions& options,
                                        std::unique_ptr<HidTransport> transport);

}  // namespace skylit::track
