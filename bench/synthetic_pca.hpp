#pragma once
// The synthetic forms both blend benchmarks (blend_bench, gpu_blend_bench) use: a random
// generator, the synthetic PCA form (synthetic_pca_basis) and the synthetic cropped form
// (synthetic_cropped_basis) of a full basis. Header-only, so that the GPU bench's standalone
// build (bench/gpu_standalone.sh) needs no further source.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::bench {

// xorshift64*, uniform in [0, 1): fast enough for the hundreds of millions of synthetic values.
struct Random {
  std::uint64_t state;
  double next() {
    state ^= state >> 12;
    state ^= state << 25;
    state ^= state >> 27;
    return static_cast<double>((state * 0x2545f4914f6cdd1dull) >> 11) * 0x1p-53;
  }
};

// The PCA form of a plane of side × side texels whose n source layers have the solid angles
// `unoccluded`: `components` + 1 stored layers (the mean in [0.3, 0.7], eigen-images in [−1, 1]),
// tiles of `tile` texels (0: untiled); each tile's projection A_l · (1, [−0.1, 0.1] …), so that
// T stays near [0, 1].
inline blend::BasisImages synthetic_pca_basis(int side, const std::vector<double>& unoccluded, int components, int tile,
                                               std::uint64_t seed) {
  Random random{seed};
  const auto next = [&random] { return random.next(); };
  blend::BasisImages basis;
  basis.name = "synthetic-pca";
  basis.width = side;
  basis.height = side;
  basis.layers = components + 1;
  basis.tile = tile;
  basis.unoccluded = unoccluded;
  basis.half.resize(basis.texel_count() * static_cast<std::size_t>(basis.layers));
  for (int i = 0; i < basis.layers; ++i) {
    std::uint16_t* layer = basis.half.data() + static_cast<std::size_t>(i) * basis.texel_count();
    for (std::size_t k = 0; k < basis.texel_count(); ++k) {
      const double value = i == 0 ? 0.3 + 0.4 * next() : 2.0 * next() - 1.0;
      layer[k] = blend::float_to_half(static_cast<float>(value));
    }
  }
  const auto n = static_cast<Eigen::Index>(unoccluded.size());
  const auto stored = static_cast<Eigen::Index>(basis.layers);
  basis.projection.resize(n, static_cast<Eigen::Index>(basis.tile_count()) * stored);
  for (Eigen::Index l = 0; l < n; ++l) {
    const double a = unoccluded[static_cast<std::size_t>(l)];
    for (Eigen::Index c = 0; c < basis.projection.cols(); ++c) {
      const double p = c % stored == 0 ? 1.0 : 0.2 * next() - 0.1;
      basis.projection(l, c) = static_cast<float>(a * p);
    }
  }
  return basis;
}

// The cropped form of `full` (square planes: width = height): each layer kept within a square of
// `fraction` of the plane's texels at a pseudo-random place, its A outside (as BasisForm::Cropped
// stores a lean layer).
inline blend::BasisImages synthetic_cropped_basis(const blend::BasisImages& full, double fraction,
                                                   std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  blend::BasisImages b = full;
  b.half.clear();
  const int side = std::max(1, static_cast<int>(std::lround(std::sqrt(fraction) * full.width)));
  std::uniform_int_distribution<int> place(0, full.width - side);
  for (int l = 0; l < full.layers; ++l) {
    blend::LayerCrop c{place(rng), place(rng), side, side, b.half.size(),
                        static_cast<float>(full.unoccluded[static_cast<std::size_t>(l)])};
    for (int r = 0; r < side; ++r) {
      const std::uint16_t* from = full.half.data() + static_cast<std::size_t>(l) * full.texel_count() +
                                  static_cast<std::size_t>(c.row + r) * static_cast<std::size_t>(full.width) +
                                  static_cast<std::size_t>(c.col);
      b.half.insert(b.half.end(), from, from + side);
    }
    b.crops.push_back(c);
  }
  return b;
}

}  // namespace skylit::bench
