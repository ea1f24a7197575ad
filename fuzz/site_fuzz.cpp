// The site file (scene::load_site): YAML from the installer, and the model and planes it names.
#include "fuzz_target.hpp"
#include "skylit/scene/site.hpp"

SKYLIT_FUZZ_TARGET(site) {
  const auto file = skylit::fuzz::write_input("site/site.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::scene::load_site(file); });
  return 0;
}
