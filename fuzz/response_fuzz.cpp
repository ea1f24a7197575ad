// A camera's radiometric response (sky::load_response), as skylit-calib response writes it.
#include "fuzz_target.hpp"
#include "skylit/sky/radiometry.hpp"

SKYLIT_FUZZ_TARGET(response) {
  const auto file = skylit::fuzz::write_input("response/response.yaml", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::sky::load_response(file); });
  return 0;
}
