// A bake's manifest.json (bake_format::read_manifest); every file an accepted manifest names
// lies inside the bake directory.
#include "fuzz_target.hpp"
#include "skylit/bake_format/manifest.hpp"

SKYLIT_FUZZ_TARGET(manifest) {
  const auto file = skylit::fuzz::write_input("bake/manifest.json", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::bake_format::read_manifest(file.parent_path()); });
  return 0;
}
