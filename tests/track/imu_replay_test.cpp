// IMU recordings: the CSV (round trip, errors), the replay driver (samples released by time, the
// end of the recording reported as a device gone), the `imu:` config node and open_imu.
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/imu.hpp"

namespace {

using namespace skylit::track;
namespace fs = std::filesystem;
using skylit::test::TempDir;
using skylit::test::error_of;


std::vector<ImuSample> ramp(int count) {
  std::vector<ImuSample> samples;
  for (int i = 0; i < count; ++i) {
    ImuSample s;
    s.timestamp = 10.0 + 0.002 * i;
    s.gyro = Eigen::Vector3d(0.01 * i, -0.5, 1e-7);
    s.accel = Eigen::Vector3d(0.1, 9.80665, -0.25 * i);
    samples.push_back(s);
  }
  return samples;
}

TEST(ImuCsv, RoundTrip) {
  TempDir dir;
  const auto samples = ramp(50);
  save_imu_csv(dir.path() / "imu.csv", samples);
  const auto loaded = load_imu_csv(dir.path() / "imu.csv");
  ASSERT_EQ(loaded.size(), samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_NEAR(loaded[i].timestamp, samples[i].timestamp, 1e-9);
    EXPECT_LT((loaded[i].gyro - samples[i].gyro).norm(), 1e-8);
    EXPECT_LT((loaded[i].accel - samples[i].accel).norm(), 1e-7);
  }
}

TEST(ImuCsv, ErrorsNameLineAndColumn) {
  TempDir dir;
  const auto error = [&](const std::string& text) {
    const fs::path file = dir.write("bad.csv", text);
    return error_of([&] { load_imu_csv(file); });
  };
  EXPECT_NE(error("t,gx,gy,gz,ax,ay,az\n").find("the header is not 'timestamp,gx,gy,gz,ax,ay,az'"), std::string::npos);
  EXPECT_NE(error("timestamp,gx,gy,gz,ax,ay,az\n").find("no samples"), std::string::npos);
  const std::string nan = error("timestamp,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0,9.8\n0.1,0,x,0,0,0,9.8\n");
  EXPECT_NE(nan.find("bad.csv:3:"), std::string::npos) << nan;
  EXPECT_NE(nan.find("'gy'"), std::string::npos) << nan;
  EXPECT_NE(error("timestamp,gx,gy,gz,ax,ay,az\n0,0,0,0,0,0\n").find("6 fields, 7 expected"), std::string::npos);
  EXPECT_NE(error("timestamp,gx,gy,gz,ax,ay,az\n1,0,0,0,0,0,9.8\n1,0,0,0,0,0,9.8\n").find("does not increase"), std::string::npos);
}

TEST(ReplayImu, ReleasesSamplesByTimeAndEndsAsGone) {
  ReplayImu imu(ramp(10), Eigen::Quaterniond(0, 1, 0, 0), "ramp");
  EXPECT_EQ(imu.state(), ImuState::Waiting);
  EXPECT_EQ(imu.describe(), "IMU replay ramp (10 samples)");
  EXPECT_NEAR(imu.R_camera_from_imu().angularDistance(Eigen::Quaterniond(0, 1, 0, 0)), 0, 1e-12);
  std::vector<ImuSample> out;
  EXPECT_EQ(imu.read(out, 9.0), 0u);
  EXPECT_EQ(imu.state(), ImuState::Waiting);
  EXPECT_EQ(imu.read(out, 10.0045), 3u);  // 10.000, 10.002, 10.004
  EXPECT_EQ(imu.state(), ImuState::Streaming);
  EXPECT_EQ(imu.read(out, 10.0045), 0u);
  EXPECT_EQ(imu.read(out, 10.018), 7u);
  EXPECT_EQ(imu.state(), ImuState::Streaming);  // the last sample is at 10.018: not past it yet
  EXPECT_EQ(imu.read(out, 10.019), 0u);
  EXPECT_EQ(imu.state(), ImuState::Gone);
  ASSERT_EQ(out.size(), 10u);
  EXPECT_DOUBLE_EQ(out.back().timestamp, 10.018);
  imu.close();
  EXPECT_EQ(imu.state(), ImuState::Closed);
  EXPECT_THROW(ReplayImu({}, Eigen::Quaterniond::Identity(), "empty"), std::invalid_argument);
}

TEST(ImuConfig, ParsedAndOpened) {
  TempDir dir;
  save_imu_csv(dir.path() / "head_imu.csv", ramp(5));
  const fs::path config = dir.write("site.yaml", "imu:\n  kind: replay\n  csv: head_imu.csv\n  R_camera_from_imu: [0, 0, 0, 1]\n");
  const ImuConfig parsed = parse_imu_config(YAML::LoadFile(config.string())["imu"], config);
  EXPECT_EQ(parsed.kind, ImuConfig::Kind::Replay);
  EXPECT_EQ(parsed.csv, dir.path() / "head_imu.csv");
  const auto imu = open_imu(parsed);
  EXPECT_EQ(imu->describe(), "IMU replay head_imu.csv (5 samples)");
  EXPECT_NEAR(imu->R_camera_from_imu().angularDistance(Eigen::Quaterniond(0, 0, 0, 1)), 0, 1e-12);

  const ImuConfig hid = parse_imu_config(YAML::Load("kind: hid\nprofile: imu/dualshock4_usb.yaml\npath: /dev/hidraw3\n"),
                                         fs::path(SKYLIT_SOURCE_DIR) / "config" / "site.yaml");
  EXPECT_EQ(hid.kind, ImuConfig::Kind::Hid);
  EXPECT_EQ(hid.profile, fs::path(SKYLIT_SOURCE_DIR) / "config" / "imu" / "dualshock4_usb.yaml");
  EXPECT_EQ(hid.path, "/dev/hidraw3");
  EXPECT_FALSE(hid.R_camera_from_imu.has_value());

  const auto error = [](const std::string& text) {
    return error_of([&] { parse_imu_config(YAML::Load(text), "site.yaml"); });
  };
  EXPECT_NE(error("kind: usb\n").find("imu.kind"), std::string::npos);
  EXPECT_NE(error("kind: hid\n").find("imu.profile"), std::string::npos);
  EXPECT_NE(error("kind: replay\ncsv: a.csv\nprofile: x.yaml\n").find("imu.profile"), std::string::npos);
  EXPECT_NE(error("kind: replay\ncsv: a.csv\nR_camera_from_imu: [1, 1, 0, 0]\n").find("not 1"), std::string::npos);
  EXPECT_NE(error("kind: replay\ncsv: a.csv\nR_camera_from_imu: [1, 0, 0]\n").find("imu.R_camera_from_imu"), std::string::npos);
}

}  // namespace
