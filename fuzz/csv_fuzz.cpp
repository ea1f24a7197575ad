// CSV files installers and recorders bring (base::parse_csv): IMU logs, pose tracks and the sun
// frames' list.
#include <string>

#include "fuzz_target.hpp"
#include "skylit/base/csv.hpp"
#include "skylit/calib/sun_frames.hpp"
#include "skylit/track/imu.hpp"
#include "skylit/track/pose.hpp"

SKYLIT_FUZZ_TARGET(csv) {
  skylit::CsvError error;
  const auto rows = skylit::parse_csv(std::string(reinterpret_cast<const char*>(data), size), &error);
  for (const auto& row : rows) skylit::fuzz::require(row.line >= 1, "rows have 1-based lines");
  const auto file = skylit::fuzz::write_input("csv/log.csv", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::track::load_imu_csv(file); });
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::track::PoseTrack::load(file); });
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::calib::read_frame_list(file); });
  return 0;
}
