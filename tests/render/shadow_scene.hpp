#pragma once
// Shared by the shadow-map tests: a 12 m ground plane of 12.5 cm texels just above the ground,
// a disc as equal-weight directions, and an open sky's basis over a plane (B = A on 40 faces, so
// that the separated sources' shadows are all there is).
#include <cmath>
#include <numbers>
#include <vector>

#include "skylit/blend/basis.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/geom/plane.hpp"

namespace skylit::render::test {

inline geom::Plane ground_plane() {
  geom::Plane plane;
  plane.name = "ground";
  plane.origin = geom::Vec3(-6, -6, 0.01);
  plane.u = geom::Vec3(12, 0, 0);
  plane.v = geom::Vec3(0, 12, 0);
  plane.width = 96;
  plane.height = 96;
  return plane;
}

// A disc of angular radius `radius` around `centre` as `count` equal-weight directions spread
// evenly over it (a sunflower pattern).
inline void disc_samples(const geom::Vec3& centre, double radius, int count, std::vector<geom::Vec3>& directions,
                         std::vector<double>& weights) {
  const geom::Vec3 w = centre.normalized();
  const geom::Vec3 helper = std::abs(w.z()) < 0.9 ? geom::Vec3::UnitZ() : geom::Vec3::UnitX();
  const geom::Vec3 a = helper.cross(w).normalized();
  const geom::Vec3 b = w.cross(a);
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  directions.clear();
  weights.assign(static_cast<std::size_t>(count), 1.0 / count);
  for (int k = 0; k < count; ++k) {
    const double r = radius * std::sqrt((k + 0.5) / count);
    const double phi = k * golden;
    directions.push_back((w + std::tan(r) * (std::cos(phi) * a + std::sin(phi) * b)).normalized());
  }
}

inline constexpr int kOpenSkyLayers = 40;

// The open sky's basis over `plane`: every layer B = A = π/40 · ½ everywhere.
inline blend::BasisImages open_sky_basis(const geom::Plane& plane) {
  const std::vector<double> A(kOpenSkyLayers, 2.0 * std::numbers::pi / kOpenSkyLayers * 0.5);
  blend::BasisImages basis;
  basis.name = plane.name;
  basis.width = plane.width;
  basis.height = plane.height;
  basis.layers = kOpenSkyLayers;
  basis.unoccluded = A;
  basis.half.assign(basis.texel_count() * kOpenSkyLayers, blend::float_to_half(static_cast<float>(A[0])));
  basis.normal = plane.normal();
  return basis;
}

}  // namespace skylit::render::test
