// OpenEXR images of a bake (bake_format::read_exr_info, read_exr_stack_half), of a sky
// (sky::read_sky_image) and an equirectangular source (sky::read_equirect).
#include "fuzz_target.hpp"
#include "skylit/bake_format/arrays.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/radiometry.hpp"

SKYLIT_FUZZ_TARGET(exr) {
  const auto file = skylit::fuzz::write_input("exr/image.exr", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::bake_format::read_exr_info(file); });
  skylit::fuzz::refuse_only_with_input_error([&] {
    const auto stack = skylit::bake_format::read_exr_stack_half(file);
    skylit::fuzz::require(stack.data.size() == std::size_t(stack.width) * std::size_t(stack.height) * std::size_t(stack.layers),
                          "a stack holds width x height x layers values");
  });
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::sky::read_sky_image(file); });
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::sky::read_equirect(file); });
  return 0;
}
