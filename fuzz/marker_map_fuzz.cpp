// An AprilTag marker map (track::load_marker_map), as skylit-calib markers writes it.
#include "fuzz_target.hpp"
#include "skylit/track/marker_map.hpp"

SKYLIT_FUZZ_TARGET(marker_map) {
  const auto file = skylit::fuzz::write_input("markers/markers.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::track::load_marker_map(file); });
  return 0;
}
