// Input reports from a HID IMU (track::HidReportDecoder with the bundled DualShock 4 profile):
// the input is a sequence of reports, each prefixed with its length byte. Every decoded sample
// is finite.
#include <cmath>
#include <optional>
#include <span>

#include "fuzz_target.hpp"
#include "skylit/track/hid_imu.hpp"

SKYLIT_FUZZ_TARGET(hid_report) {
  static const skylit::track::HidImuProfile profile =
      skylit::track::load_hid_imu_profile(SKYLIT_SOURCE_DIR "/config/imu/dualshock4_usb.yaml");
  skylit::track::HidReportDecoder decoder(profile);
  skylit::track::ImuSample sample;
  double receive = 0;
  for (std::size_t at = 0; at < size;) {
    const std::size_t length = std::min<std::size_t>(data[at], size - at - 1);
    const std::span<const std::uint8_t> report(data + at + 1, length);
    at += 1 + length;
    receive += 0.004;
    if (decoder.decode(report, receive, sample) == skylit::track::DecodeStatus::Ok) {
      skylit::fuzz::require(std::isfinite(sample.timestamp) && sample.gyro.allFinite() && sample.accel.allFinite(),
                            "a decoded IMU sample is finite");
    }
  }
  return 0;
}
