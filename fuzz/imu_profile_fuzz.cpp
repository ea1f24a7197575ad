// A HID IMU profile (track::load_hid_imu_profile); an accepted one decodes reports of every
// length up to its own without reading past them.
#include <vector>

#include "fuzz_target.hpp"
#include "skylit/track/hid_imu.hpp"

SKYLIT_FUZZ_TARGET(imu_profile) {
  const auto file = skylit::fuzz::write_input("imu/imu.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] {
    skylit::track::HidReportDecoder decoder(skylit::track::load_hid_imu_profile(file));
    std::vector<std::uint8_t> report;
    skylit::track::ImuSample sample;
    for (std::size_t length = 0; length <= 128; ++length) {
      report.assign(length, static_cast<std::uint8_t>(length * 37));
      (void)decoder.decode(report, 0.01 * static_cast<double>(length), sample);
    }
  });
  return 0;
}
