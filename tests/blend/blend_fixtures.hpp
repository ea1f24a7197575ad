#pragma once
// Shared by the render tests: basis images built in memory, and random skies and planes shaped
// like real ones (faces the plane cannot see, dark faces, full shadow and full light).
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/half.hpp"

namespace skylit::blend::test {

// B(layer, texel) as a float, stored as the nearest half.
inline BasisImages make_basis(int width, int height, std::vector<double> unoccluded,
                              const std::function<float(int layer, std::size_t texel)>& value) {
  BasisImages basis;
  basis.name = "test";
  basis.width = width;
  basis.height = height;
  basis.layers = static_cast<int>(unoccluded.size());
  basis.unoccluded = std::move(unoccluded);
  basis.half.resize(basis.texel_count() * static_cast<std::size_t>(basis.layers));
  for (int i = 0; i < basis.layers; ++i) {
    for (std::size_t t = 0; t < basis.texel_count(); ++t) {
      basis.half[static_cast<std::size_t>(i) * basis.texel_count() + t] = float_to_half(value(i, t));
    }
  }
  return basis;
}

struct RandomScene {
  BasisImages basis;
  std::vector<Eigen::Vector3d> S;
  SunLight sun;
  std::vector<float> visibility;
};

// n faces of a hemisphere of solid angle 2π: about a quarter unseen by the plane (A = 0), a fifth
// dark (S = 0 in some channel), B = A·f with f = 0, 1 or anything between; the sun at 60°
// elevation, partly shadowed.
inline RandomScene random_scene(int layers, int width, int height, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double omega = 2.0 * std::numbers::pi / layers;
  std::vector<double> A(static_cast<std::size_t>(layers));
  for (double& a : A) a = uniform(rng) < 0.25 ? 0.0 : omega * (0.05 + 0.95 * uniform(rng));
  std::vector<float> fractions(static_cast<std::size_t>(layers) * static_cast<std::size_t>(width) *
                               static_cast<std::size_t>(height));
  for (float& f : fractions) {
    const double pick = uniform(rng);
    f = pick < 0.3 ? 0.0f : (pick < 0.6 ? 1.0f : static_cast<float>(uniform(rng)));
  }
  RandomScene scene;
  const std::size_t texels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  scene.basis = make_basis(width, height, A, [&](int i, std::size_t t) {
    return static_cast<float>(A[static_cast<std::size_t>(i)] * fractions[static_cast<std::size_t>(i) * texels + t]);
  });
  for (int i = 0; i < layers; ++i) {
    Eigen::Vector3d s(uniform(rng), uniform(rng), uniform(rng));
    s *= 4.0;
    if (uniform(rng) < 0.2) s[static_cast<int>(uniform(rng) * 3) % 3] = 0.0;
    if (uniform(rng) < 0.1) s.setZero();
    scene.S.push_back(s);
  }
  scene.sun.direction = Vec3(std::cos(std::numbers::pi / 3), 0.0, std::sin(std::numbers::pi / 3));
  scene.sun.energy = Eigen::Vector3d(3.0, 2.8, 2.5);
  scene.visibility.resize(texels);
  for (float& v : scene.visibility) {
    const double pick = uniform(rng);
    v = pick < 0.4 ? 0.0f : (pick < 0.8 ? 1.0f : static_cast<float>(uniform(rng)));
  }
  return scene;
}

}  // namespace skylit::blend::test
