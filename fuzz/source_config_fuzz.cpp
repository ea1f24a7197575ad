// A camera source's config (capture::load_source_config): files, V4L2, libcamera, a pair.
#include "fuzz_target.hpp"
#include "skylit/capture/config.hpp"

SKYLIT_FUZZ_TARGET(source_config) {
  const auto file = skylit::fuzz::write_input("source/source.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::capture::load_source_config(file); });
  return 0;
}
