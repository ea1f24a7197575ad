// The HID reader's thread over a scripted transport: a DualShock 4 that streams, is unplugged
// (the source says Gone), comes back (reopened, streaming again), and one that cannot be opened.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <thread>

#include <gtest/gtest.h>

#include "skylit/base/error.hpp"
#include "skylit/track/hid_imu.hpp"

namespace {

using namespace skylit::track;
namespace fs = std::filesystem;

// A DualShock 4 on a scripted bus: reports with a gyro x of 1000 counts and a counter that
// advances 1 ms per report.
class ScriptedDs4 final : public HidTransport {
 public:
  struct Script {
    std::mutex mutex;
    bool plugged = true;
    bool openable = true;
    int opens = 0;
    unsigned counter = 0;
  };
  explicit ScriptedDs4(std::shared_ptr<Script> script) : script_(std::move(script)) {}

  std::vector<HidDeviceInfo> enumerate() override {
    const std::lock_guard lock(script_->mutex);
    std::vector<HidDeviceInfo> devices;
    HidDeviceInfo mouse;
    mouse.vendor_id = 0x046d;
    mouse.product_id = 0xc077;
    mouse.product = "USB Optical Mouse";
    mouse.path = "/dev/hidraw0";
    devices.push_back(mouse);
    if (script_->plugged) {
      HidDeviceInfo ds4;
      ds4.vendor_id = 0x054c;
      ds4.product_id = 0x09cc;
      ds4.product = "Wireless Controller";
      ds4.path = "/dev/hidraw7";
      devices.push_back(ds4);
    }
    return devices;
  }
  bool open(const std::string& path) override {
    const std::lock_guard lock(script_->mutex);
    if (!script_->plugged || !script_->openable || path != "/dev/hidraw7") return false;
    ++script_->opens;
    open_ = true;
    return true;
  }
  int read(std::span<std::uint8_t> buffer, int /*timeout_ms*/) override {
    {
      const std::lock_guard lock(script_->mutex);
      if (!open_ || !script_->plugged) return -1;
      script_->counter = (script_->counter + 188) & 0xFFFF;  // 188 · 16/3 µs ≈ 1 ms
      std::fill(buffer.begin(), buffer.begin() + 64, std::uint8_t{0});
      buffer[0] = 0x01;
      buffer[10] = static_cast<std::uint8_t>(script_->counter & 0xFF);
      buffer[11] = static_cast<std::uint8_t>(script_->counter >> 8);
      buffer[13] = 0xE8;  // gyro x = 1000
      buffer[14] = 0x03;
      buffer[21] = 0x00;  // accel y = 8192: 1 g
      buffer[22] = 0x20;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a device's pace, not a busy loop
    return 64;
  }
  void close() override { open_ = false; }
  std::string last_error() override { return "Permission denied"; }

 private:
  std::shared_ptr<Script> script_;
  bool open_ = false;
};

// Waits (up to 5 s, generous for a loaded machine) for the source to reach `state`.
bool wait_for(const ImuSource& source, ImuState state) {
  for (int i = 0; i < 5000 && source.state() != state; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return source.state() == state;
}

HidImuProfile ds4_profile() { return load_hid_imu_profile(fs::path(SKYLIT_SOURCE_DIR) / "config" / "imu" / "dualshock4_usb.yaml"); }

TEST(HidImuReader, StreamsGoesAwayAndComesBack) {
  auto script = std::make_shared<ScriptedDs4::Script>();
  HidImuOptions options;
  options.reconnect_first = 0.005;
  options.reconnect_max = 0.02;
  const auto imu = open_hid_imu(ds4_profile(), options, std::make_unique<ScriptedDs4>(script));
  EXPECT_EQ(imu->describe(), "Sony DualShock 4 (USB) 054c:09cc at /dev/hidraw7");
  ASSERT_TRUE(wait_for(*imu, ImuState::Streaming));

  std::vector<ImuSample> samples;
  for (int i = 0; i < 5000 && samples.size() < 20; ++i) {
    imu->read(samples, 1e300);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_GE(samples.size(), 20u);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    EXPECT_NEAR(samples[i].gyro.x(), 1000 * 1.0652644e-3, 1e-9);
    EXPECT_NEAR(samples[i].accel.y(), 9.80665, 1e-6);
    if (i > 0) {
      EXPECT_GT(samples[i].timestamp, samples[i - 1].timestamp);
    }
  }
  // Samples stay queued until asked for by time.
  std::vector<ImuSample> none;
  EXPECT_EQ(imu->read(none, samples.front().timestamp - 1.0), 0u);

  {
    const std::lock_guard lock(script->mutex);
    script->plugged = false;
  }
  ASSERT_TRUE(wait_for(*imu, ImuState::Gone));
  {
    const std::lock_guard lock(script->mutex);
    script->plugged = true;
  }
  ASSERT_TRUE(wait_for(*imu, ImuState::Streaming));
  {
    const std::lock_guard lock(script->mutex);
    EXPECT_EQ(script->opens, 2);
  }
  imu->close();
  EXPECT_EQ(imu->state(), ImuState::Closed);
  imu->close();  // idempotent
}

TEST(HidImuReader, DeviceThatCannotBeOpenedIsAnInputError) {
  auto script = std::make_shared<ScriptedDs4::Script>();
  script->openable = false;
  try {
    open_hid_imu(ds4_profile(), {}, std::make_unique<ScriptedDs4>(script));
    FAIL() << "no InputError";
  } catch (const skylit::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("cannot be opened (/dev/hidraw7: Permission denied)"), std::string::npos) << message;
    EXPECT_NE(message.find("udev rule"), std::string::npos) << message;
  }
  script->openable = true;
  script->plugged = false;
  try {
    open_hid_imu(ds4_profile(), {}, std::make_unique<ScriptedDs4>(script));
    FAIL() << "no InputError";
  } catch (const skylit::InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("HID devices present: 046d:c077 'USB Optical Mouse' at /dev/hidraw0"), std::string::npos) << message;
  }
}

}  // namespace
