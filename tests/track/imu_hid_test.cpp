// The HID IMU decoder on hand-built reports (byte layouts, endianness, scale, axis mapping,
// report id mismatch, short reports, counters that wrap), the device clock, the DualShock 4
// profile on real reports, profile errors, and hidapi on a machine without the device.
#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <unistd.h>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/hid_imu.hpp"

namespace {

using namespace skylit::track;
namespace fs = std::filesystem;
using skylit::test::TempDir;
using skylit::test::error_of;
using Bytes = std::vector<std::uint8_t>;

const fs::path kProfiles = fs::path(SKYLIT_SOURCE_DIR) / "config" / "imu";


double raw(const Bytes& bytes, std::size_t offset, HidFieldType type, Endian endian) {
  HidField field;
  field.offset = offset;
  field.type = type;
  field.endian = endian;
  return read_raw(bytes, field);
}

TEST(HidField, TypesAndByteOrders) {
  const Bytes b{0x34, 0x12, 0xFF, 0xFE, 0x78, 0x56, 0x34, 0x12, 0xFF, 0xFF, 0xFF, 0xFF, 0x00, 0x00, 0xC0, 0x3F, 0x3F, 0xC0, 0x00, 0x00};
  EXPECT_EQ(raw(b, 0, HidFieldType::Int16, Endian::Little), 0x1234);
  EXPECT_EQ(raw(b, 0, HidFieldType::Int16, Endian::Big), 0x3412);
  EXPECT_EQ(raw(b, 2, HidFieldType::Int16, Endian::Little), -257);  // 0xFEFF
  EXPECT_EQ(raw(b, 2, HidFieldType::Int16, Endian::Big), -2);       // 0xFFFE
  EXPECT_EQ(raw(b, 2, HidFieldType::UInt16, Endian::Big), 65534);
  EXPECT_EQ(raw(b, 2, HidFieldType::Int8, Endian::Little), -1);
  EXPECT_EQ(raw(b, 2, HidFieldType::UInt8, Endian::Little), 255);
  EXPECT_EQ(raw(b, 4, HidFieldType::Int32, Endian::Little), 0x12345678);
  EXPECT_EQ(raw(b, 4, HidFieldType::Int32, Endian::Big), 0x78563412);
  EXPECT_EQ(raw(b, 8, HidFieldType::Int32, Endian::Little), -1);
  EXPECT_EQ(raw(b, 8, HidFieldType::UInt32, Endian::Little), 4294967295.0);
  EXPECT_EQ(raw(b, 12, HidFieldType::Float32, Endian::Little), 1.5);
  EXPECT_EQ(raw(b, 16, HidFieldType::Float32, Endian::Big), 1.5);
  EXPECT_EQ(field_size(HidFieldType::Float32), 4u);
}

// A made-up device that uses every feature: report id 0x21, big-endian int16 gyro, little-endian
// float accelerometer, a big-endian microsecond counter, axes remapped.
const char* const kCustomProfile = R"(
name: Test IMU
vendor_id: 0x1234
product_id: 0x5678
report_id: 0x21
report_size: 32
timestamp: {offset: 21, type: uint32, endian: big, scale: 1.0e-6}
gyro: {offsets: [3, 5, 7], type: int16, endian: big, scale: 0.001}
accel: {offsets: [9, 13, 17], type: float32, endian: little, scale: 1}
axes: [y, -x, z]
R_camera_from_imu: [0.70710678, 0, 0, 0.70710678]
)";

void put_be16(Bytes& b, std::size_t at, std::int16_t v) {
  const auto u = static_cast<std::uint16_t>(v);
  b[at] = static_cast<std::uint8_t>(u >> 8);
  b[at + 1] = static_cast<std::uint8_t>(u & 0xFF);
}
void put_be32(Bytes& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
}
void put_le_float(Bytes& b, std::size_t at, float f) {
  const auto u = std::bit_cast<std::uint32_t>(f);
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(u >> (8 * i));
}

Bytes custom_report(std::uint32_t micros) {
  Bytes r(32, 0);
  r[0] = 0x21;
  put_be16(r, 3, 1000);
  put_be16(r, 5, -2000);
  put_be16(r, 7, 3000);
  put_le_float(r, 9, 0.5f);
  put_le_float(r, 13, 9.75f);
  put_le_float(r, 17, -1.25f);
  put_be32(r, 21, micros);
  return r;
}

TEST(HidReportDecoder, ScalesMapsAxesAndStampsOnTheHostClock) {
  TempDir dir;
  const HidImuProfile profile = load_hid_imu_profile(dir.write("test.yaml", kCustomProfile));
  EXPECT_TRUE(profile.matches(0x1234, 0x5678));
  EXPECT_FALSE(profile.matches(0x1234, 0x5679));
  EXPECT_NEAR(profile.R_camera_from_imu.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()))), 0, 1e-6);
  HidReportDecoder decoder(profile);
  ImuSample s;
  ASSERT_EQ(decoder.decode(custom_report(1'000'000), 100.0, s), DecodeStatus::Ok);
  // Device gyro (1, -2, 3) rad/s; IMU = (y, -x, z).
  EXPECT_NEAR((s.gyro - Eigen::Vector3d(-2, -1, 3)).norm(), 0, 1e-12);
  EXPECT_NEAR((s.accel - Eigen::Vector3d(9.75, -0.5, -1.25)).norm(), 0, 1e-6);
  EXPECT_DOUBLE_EQ(s.timestamp, 100.0);
  // 4 ms later on the device, received 0.9 ms later than the first one's delay: stamped at the
  // device's time (plus the drift allowance, 2e-4 · 4 ms); then one that came quicker moves the
  // offset down.
  ASSERT_EQ(decoder.decode(custom_report(1'004'000), 100.0049, s), DecodeStatus::Ok);
  EXPECT_NEAR(s.timestamp, 100.004, 1e-6);
  ASSERT_EQ(decoder.decode(custom_report(1'008'000), 100.0075, s), DecodeStatus::Ok);
  EXPECT_NEAR(s.timestamp, 100.0075, 1e-9);

  Bytes other = custom_report(0);
  other[0] = 0x22;
  EXPECT_EQ(decoder.decode(other, 100.01, s), DecodeStatus::WrongReportId);
  EXPECT_EQ(decoder.decode(Bytes{}, 100.01, s), DecodeStatus::WrongReportId);
  Bytes shorter = custom_report(0);
  shorter.resize(24);  // the timestamp ends at byte 24
  EXPECT_EQ(decoder.decode(shorter, 100.01, s), DecodeStatus::TooShort);
}

TEST(HidReportDecoder, UnnumberedReportsAndNoTimestamp) {
  TempDir dir;
  const HidImuProfile profile = load_hid_imu_profile(dir.write("plain.yaml", R"(
name: Plain
vendor_id: 1
product_id: 2
report_size: 12
gyro: {offsets: [0, 2, 4], type: int16, scale: [0.01, -0.01, 0.02]}
accel: {offsets: [6, 8, 10], type: uint16, endian: little, scale: 0.5}
)"));
  HidReportDecoder decoder(profile);
  const Bytes report{0x64, 0x00, 0x64, 0x00, 0x64, 0x00, 0x02, 0x00, 0x04, 0x00, 0xFF, 0xFF};
  ImuSample s;
  ASSERT_EQ(decoder.decode(report, 7.5, s), DecodeStatus::Ok);
  EXPECT_NEAR((s.gyro - Eigen::Vector3d(1.0, -1.0, 2.0)).norm(), 0, 1e-12);  // per-axis scales, one negative
  EXPECT_NEAR((s.accel - Eigen::Vector3d(1.0, 2.0, 32767.5)).norm(), 0, 1e-9);
  EXPECT_EQ(s.timestamp, 7.5);  // the receive time
}

// The DualShock 4's 16-bit counter (16/3 µs per count) wraps every 0.35 s: unwrapped, and a stall
// longer than a wrap is counted from the host's clock.
TEST(HidReportDecoder, CounterWrapsAreUnwrapped) {
  const HidImuProfile profile = load_hid_imu_profile(kProfiles / "dualshock4_usb.yaml");
  HidReportDecoder decoder(profile);
  const double tick = 16.0 / 3.0 * 1e-6;
  const auto report = [](unsigned count) {
    Bytes r(64, 0);
    r[0] = 0x01;
    r[10] = static_cast<std::uint8_t>(count & 0xFF);
    r[11] = static_cast<std::uint8_t>((count >> 8) & 0xFF);
    return r;
  };
  ImuSample s;
  ASSERT_EQ(decoder.decode(report(65000), 50.0, s), DecodeStatus::Ok);
  const double t0 = s.timestamp;
  ASSERT_EQ(decoder.decode(report(500), 50.0 + 1036 * tick, s), DecodeStatus::Ok);  // wrapped
  EXPECT_NEAR(s.timestamp - t0, 1036 * tick, 1e-9);
  // One second without reports (about 2.9 wraps), then the next.
  const unsigned later = (500 + static_cast<unsigned>(std::lround(1.0 / tick))) % 65536;
  ASSERT_EQ(decoder.decode(report(later), 50.0 + 1036 * tick + 1.0, s), DecodeStatus::Ok);
  EXPECT_NEAR(s.timestamp - t0, 1036 * tick + 1.0, tick);
}

// Host receive times = device time + offset + a delay of 0.5 ms plus an exponential part (mean
// 1 ms); the device's clock 100 ppm slow. The mapped times stay within 0.3 ms of device time +
// offset + minimum delay, where the receive times scatter by a millisecond.
TEST(DeviceClock, FollowsTheLeastDelayedReportsAndDrift) {
  std::mt19937 rng(7);
  std::exponential_distribution<double> delay(1000.0);
  DeviceClock clock;
  double worst = 0, receive_spread = 0;
  for (int k = 0; k < 250 * 60; ++k) {
    const double device = k / 250.0;
    const double host_truth = 12.0 + device * (1.0 + 1e-4) + 0.0005;
    const double received = host_truth + delay(rng);
    const double mapped = clock.to_host(device, received);
    if (k > 250) {
      worst = std::max(worst, std::abs(mapped - host_truth));
      receive_spread = std::max(receive_spread, received - host_truth);
    }
  }
  std::printf("mapped within %.3f ms of the truth; receive times up to %.3f ms late\n", worst * 1e3, receive_spread * 1e3);
  EXPECT_LT(worst, 0.3e-3);
  EXPECT_GT(receive_spread, 5e-3);
}

// Eight input reports of a DualShock 4 compatible controller lying still, as published with
// ds4dump (github.com/im-0/random-things, ds4dump/README.md, "Chinese clone #1"): the first 26
// bytes of each (the rest is touchpad data).
TEST(DualShock4Profile, DecodesRealReports) {
  const std::vector<Bytes> reports{
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xcc, 0x00, 0x00, 0x73, 0x13, 0x00, 0xe9, 0xff, 0xf9, 0xff, 0xed, 0xff, 0x54, 0x00, 0xf2, 0x1e, 0x4f, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xd4, 0x00, 0x00, 0x5f, 0x16, 0x00, 0xea, 0xff, 0xf9, 0xff, 0xef, 0xff, 0x44, 0x00, 0x86, 0x1f, 0x85, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xdc, 0x00, 0x00, 0x4b, 0x19, 0x00, 0xee, 0xff, 0xf9, 0xff, 0xf3, 0xff, 0x28, 0x00, 0x8f, 0x20, 0xc2, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xe4, 0x00, 0x00, 0x37, 0x1c, 0x00, 0xf2, 0xff, 0xf8, 0xff, 0xf7, 0xff, 0x1f, 0x00, 0xda, 0x20, 0xd1, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xec, 0x00, 0x00, 0x23, 0x1f, 0x00, 0xf2, 0xff, 0xf8, 0xff, 0xf7, 0xff, 0x19, 0x00, 0xa7, 0x20, 0x9f, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xf4, 0x00, 0x00, 0x0f, 0x22, 0x00, 0xef, 0xff, 0xf8, 0xff, 0xf5, 0xff, 0x22, 0x00, 0xbd, 0x20, 0x9b, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0xfc, 0x00, 0x00, 0xfb, 0x24, 0x00, 0xef, 0xff, 0xf8, 0xff, 0xf2, 0xff, 0x37, 0x00, 0x6e, 0x20, 0x94, 0x05, 0x00},
      {0x01, 0x80, 0x80, 0x80, 0x80, 0x08, 0x00, 0x04, 0x00, 0x00, 0xe7, 0x27, 0x00, 0xed, 0xff, 0xf8, 0xff, 0xeb, 0xff, 0x5e, 0x00, 0x44, 0x1f, 0x6c, 0x05, 0x00},
  };
  const auto profiles = load_hid_imu_profiles(kProfiles);
  const auto ds4 = std::find_if(profiles.begin(), profiles.end(), [](const HidImuProfile& p) { return p.matches(0x054c, 0x05c4); });
  ASSERT_NE(ds4, profiles.end());
  EXPECT_TRUE(ds4->matches(0x054c, 0x09cc));
  HidReportDecoder decoder(*ds4);
  std::vector<ImuSample> samples;
  for (std::size_t i = 0; i < reports.size(); ++i) {
    ImuSample s;
    ASSERT_EQ(decoder.decode(reports[i], 20.0 + 0.004 * static_cast<double>(i), s), DecodeStatus::Ok) << i;
    samples.push_back(s);
  }
  for (std::size_t i = 1; i < samples.size(); ++i) {
    // 748 counts of 16/3 µs between reports: 250 reports per second over USB (the host's 4 ms
    // steps move the stamps by no more than the drift allowance, 2e-4 · 4 ms).
    EXPECT_NEAR(samples[i].timestamp - samples[i - 1].timestamp, 748 * 16.0 / 3.0 * 1e-6, 1e-6);
  }
  for (const auto& s : samples) {
    EXPECT_NEAR(s.accel.norm(), 9.81, 0.05 * 9.81);   // gravity, within the unit's 5 % of nominal scale
    EXPECT_GT(s.accel.y(), 0.97 * s.accel.norm());    // lying face up: y is up
    EXPECT_LT(s.gyro.norm(), 0.05);                    // still: a bias of about 1 °/s
    EXPECT_GT(s.gyro.norm(), 0.0);
  }
}

TEST(HidImuProfile, ErrorsNameTheFieldAndTheFix) {
  TempDir dir;
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string text = kCustomProfile;
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const fs::path file = dir.write("bad.yaml", text);
    return error_of([&] { load_hid_imu_profile(file); });
  };
  EXPECT_NE(with("report_size: 32", "report_sise: 32").find("did you mean 'report_size'"), std::string::npos);
  const std::string past = with("offsets: [3, 5, 7]", "offsets: [3, 5, 31]");
  EXPECT_NE(past.find("gyro.offsets"), std::string::npos) << past;
  EXPECT_NE(past.find("end past report_size 32"), std::string::npos) << past;
  EXPECT_NE(past.find("bad.yaml:8:"), std::string::npos) << past;
  EXPECT_NE(with("type: int16", "type: int12").find("gyro.type"), std::string::npos);
  EXPECT_NE(with("endian: big, scale: 0.001", "endian: middle, scale: 0.001").find("gyro.endian"), std::string::npos);
  EXPECT_NE(with("axes: [y, -x, z]", "axes: [y, -y, z]").find("appears twice"), std::string::npos);
  EXPECT_NE(with("axes: [y, -x, z]", "axes: [y, x, z]").find("mirrors"), std::string::npos);
  EXPECT_NE(with("axes: [y, -x, z]", "axes: [y, w, z]").find("'w' is not an axis"), std::string::npos);
  EXPECT_NE(with("product_id: 0x5678", "product_id: []").find("product_id"), std::string::npos);
  EXPECT_NE(with("vendor_id: 0x1234", "vendor_id: 0x12345").find("vendor_id"), std::string::npos);
  EXPECT_NE(with("scale: 1.0e-6", "scale: 0").find("timestamp.scale"), std::string::npos);
  EXPECT_NE(with("scale: 1}", "scale: 0}").find("accel.scale"), std::string::npos);
  EXPECT_NE(with("[0.70710678, 0, 0, 0.70710678]", "[1, 1, 0, 0]").find("R_camera_from_imu"), std::string::npos);
  EXPECT_NE(error_of([&] { load_hid_imu_profile(dir.write("empty.yaml", "- 1\n")); }).find("expected a map"), std::string::npos);
}

// hidapi itself: listing must work (an empty list on a machine without HID devices), and opening
// a device that is not there fails naming the ids, the profile and what is there.
TEST(HidApi, EnumerateAndOpenWithoutTheDevice) {
  const auto profiles = load_hid_imu_profiles(kProfiles);
  const auto devices = enumerate_hid_devices(profiles);
  for (const auto& d : devices) {
    bool matched = false;
    for (const auto& p : profiles) matched = matched || p.matches(d.vendor_id, d.product_id);
    EXPECT_EQ(matched, !d.profile.empty()) << d.path;
    EXPECT_FALSE(d.path.empty());
  }
  TempDir dir;
  // pid.codes' test ids: no real product carries them.
  const HidImuProfile absent = load_hid_imu_profile(dir.write("absent.yaml", R"(
name: Absent IMU
vendor_id: 0x1209
product_id: [0x0001, 0x0002]
report_size: 8
gyro: {offsets: [0, 2, 4], type: int16, scale: 0.001}
accel: {offsets: [0, 2, 4], type: int16, scale: 0.001}
)"));
  const std::string message = error_of([&] { open_hid_imu(absent); });
  EXPECT_NE(message.find("absent.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("no HID device matches vendor_id 0x1209, product_id 0x0001 or 0x0002"), std::string::npos) << message;
  EXPECT_NE(message.find("HID devices present: "), std::string::npos) << message;
  if (devices.empty()) {
    EXPECT_NE(message.find("HID devices present: none"), std::string::npos) << message;
  }
  HidImuOptions options;
  options.path = "/dev/hidraw-none";
  EXPECT_NE(error_of([&] { open_hid_imu(absent, options); }).find("is at /dev/hidraw-none"), std::string::npos);
}

}  // namespace
