// An HMD's display profile (render::load_hmd_profile): panel, lenses, IPD.
#include "fuzz_target.hpp"
#include "skylit/render/hmd_profile.hpp"

SKYLIT_FUZZ_TARGET(hmd_profile) {
  const auto file = skylit::fuzz::write_input("hmd/hmd.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::render::load_hmd_profile(file); });
  return 0;
}
