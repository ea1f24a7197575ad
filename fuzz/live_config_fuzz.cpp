// skylit-live's config (live::load_live_config) and the sky node's (load_sky_node_config): the
// same bytes through both, as one YAML file may be given to either program.
#include "fuzz_target.hpp"
#include "skylit/live/live_config.hpp"

SKYLIT_FUZZ_TARGET(live_config) {
  const auto file = skylit::fuzz::write_input("live/live.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::live::load_live_config(file); });
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::live::load_sky_node_config(file); });
  return 0;
}
