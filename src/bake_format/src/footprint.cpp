// analyse_footprint: which layers of a plane carry a shadow, and where (footprint.hpp).
#include "skylit/bake_format/footprint.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Imath/half.h>

namespace skylit::bake_format {
namespace {

float from_half(std::uint16_t bits) {
  Imath::half h;
  h.setBits(bits);
  return static_cast<float>(h);
}
float as_stored(float value) { return static_cast<float>(Imath::half(value)); }

// value(l, texel) gives B as stored.
template <class Value>
PlaneFootprint analyse(int width, int height, int layers, std::span<const double> unoccluded, double tolerance,
                       Value value) {
  if (width < 0 || height < 0 || layers < 0 || unoccluded.size() != static_cast<std::size_t>(layers)) {
    throw std::invalid_argument("analyse_footprint: " + std::to_string(unoccluded.size()) + " unoccluded values for " +
                                std::to_string(layers) + " layers");
  }
  if (!(tolerance >= 0.0 && tolerance < 1.0)) {
    throw std::invalid_argument("analyse_footprint: tolerance " + std::to_string(tolerance) + " is not in [0, 1)");
  }
  PlaneFootprint footprint;
  footprint.texels = static_cast<std::uint64_t>(width) * static_cast<std::uint64_t>(height);
  for (int l = 0; l < layers; ++l) {
    LayerFootprint layer;
    const double a = unoccluded[static_cast<std::size_t>(l)];
    if (!(a > 0.0)) {
      layer.kind = LayerFootprint::Kind::Dark;
      ++footprint.dark;
      footprint.layers.push_back(layer);
      continue;
    }
    // A as stored for an unshadowed texel is A rounded to half; compare against the bigger of
    // the two so that rounding never counts as shadow.
    const double threshold = tolerance * a;
    const double a_stored = std::max(a, static_cast<double>(as_stored(static_cast<float>(a))));
    int col0 = width, row0 = height, col1 = -1, row1 = -1;
    for (int row = 0; row < height; ++row) {
      for (int col = 0; col < width; ++col) {
        const double b = value(l, static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col));
        // NaN counts as shadow: it must stay in the data for the loader to refuse it.
        if (!(a_stored - b <= threshold)) {
          col0 = std::min(col0, col);
          col1 = std::max(col1, col);
          row0 = std::min(row0, row);
          row1 = std::max(row1, row);
        }
      }
    }
    if (col1 < 0) {
      layer.kind = LayerFootprint::Kind::Unshadowed;
      ++footprint.unshadowed;
    } else {
      layer.kind = LayerFootprint::Kind::Shadowed;
      layer.col = col0;
      layer.row = row0;
      layer.cols = col1 - col0 + 1;
      layer.rows = row1 - row0 + 1;
      ++footprint.shadowed;
      footprint.shadowed_texels += static_cast<std::uint64_t>(layer.cols) * static_cast<std::uint64_t>(layer.rows);
    }
    footprint.layers.push_back(layer);
  }
  return footprint;
}

}  // namespace

PlaneFootprint analyse_footprint(const ImageStack& stack, std::span<const double> unoccluded, double tolerance) {
  const std::size_t texels = static_cast<std::size_t>(std::max(stack.width, 0)) * static_cast<std::size_t>(std::max(stack.height, 0));
  if (stack.data.size() != texels * static_cast<std::size_t>(std::max(stack.layers, 0))) {
    throw std::invalid_argument("analyse_footprint: the stack's size does not match its data");
  }
  return analyse(stack.width, stack.height, stack.layers, unoccluded, tolerance, [&](int l, std::size_t t) {
    return static_cast<double>(as_stored(stack.data[static_cast<std::size_t>(l) * texels + t]));
  });
}

PlaneFootprint analyse_footprint(const ImageStackHalf& stack, std::span<const double> unoccluded, double tolerance) {
  const std::size_t texels = static_cast<std::size_t>(std::max(stack.width, 0)) * static_cast<std::size_t>(std::max(stack.height, 0));
  if (stack.data.size() != texels * static_cast<std::size_t>(std::max(stack.layers, 0))) {
    throw std::invalid_argument("analyse_footprint: the stack's size does not match its data");
  }
  return analyse(stack.width, stack.height, stack.layers, unoccluded, tolerance, [&](int l, std::size_t t) {
    return static_cast<double>(from_half(stack.data[static_cast<std::size_t>(l) * texels + t]));
  });
}

}  // namespace skylit::bake_format
