// A presets file (PresetsFile) and every preset in it, for the baker and for the live service.
#include "fuzz_target.hpp"
#include "skylit/baker/preset.hpp"
#include "skylit/base/presets.hpp"
#include "skylit/live/live_config.hpp"

SKYLIT_FUZZ_TARGET(presets) {
  const auto file = skylit::fuzz::write_input("presets/presets.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] {
    const skylit::PresetsFile presets(file);
    for (const std::string& name : presets.names()) {
      skylit::fuzz::refuse_only_with_input_error([&] { skylit::baker::load_bake_preset(presets, name); });
      skylit::fuzz::refuse_only_with_input_error([&] { skylit::live::load_live_preset(presets, name); });
    }
  });
  return 0;
}
