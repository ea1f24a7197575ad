// NumPy .npy arrays of a bake (bake_format::read_npy_info, read_npy): an accepted header's shape
// is what the data holds.
#include <functional>
#include <numeric>

#include "fuzz_target.hpp"
#include "skylit/bake_format/arrays.hpp"

SKYLIT_FUZZ_TARGET(npy) {
  const auto file = skylit::fuzz::write_input("npy/array.npy", data, size);
  skylit::fuzz::refuse_only_with_input_error([&] { skylit::bake_format::read_npy_info(file); });
  skylit::fuzz::refuse_only_with_input_error([&] {
    std::vector<std::size_t> shape;
    const std::vector<float> values = skylit::bake_format::read_npy(file, &shape);
    const std::size_t count = std::accumulate(shape.begin(), shape.end(), std::size_t{1}, std::multiplies<>());
    skylit::fuzz::require(count == values.size(), "an array holds what its shape says");
  });
  return 0;
}
