#pragma once
// The ground's light on the model (docs/method.md, "Light from the ground"): a lambertian ground,
// the plane z = 0 of the site frame, lit through every basis layer with the model's shadow on it,
// and its transfer to each vertex past the model; the live service adds ρ Σ_l S_l t^g_{v,l}.
#include <cstdint>
#include <span>
#include <vector>

#include "skylit/baker/visibility.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::baker {

// `samples` directions below the horizon, each of equal solid angle 2π / samples: a Fibonacci
// lattice on the lower hemisphere (z_k = −(k + ½) / samples, turning by the golden angle).
std::vector<Vec3> ground_directions(int samples);

// ∫_{ω_z < 0} max(0, n·ω) dω = π (1 − n_z) / 2: what a vertex with unit normal n receives from
// a ground of radiance 1 that nothing hides.
double unoccluded_ground_transfer(const Vec3& normal);

// The ground's irradiance per basis layer, B_l(g) = A_l(z) f_l(g) as the bake's planes hold it
// (the model's shadow on the ground), on a grid over the model's footprint widened by twice its
// height (where its shadow falls down to a sun 27° high), at `spacing` metres or coarser so that
// no side has more than max_side texels. Outside the grid the ground is unshadowed: A_l(z).
struct GroundGrid {
  geom::Plane plane;                 // horizontal, at z = 0
  std::vector<double> unoccluded;    // A_l(z), one per layer
  std::vector<float> irradiance;     // B_l per texel, texel-major: [texel · layers + l]
  std::vector<std::uint8_t> covered; // per texel: 1 where no layer lights it (the model stands there)

  std::size_t layers() const { return unoccluded.size(); }
  // out[l] += weight · B_l(x, y), bilinear between the texel centres that are not covered (a
  // point a vertex sees lies beside the model, not under it).
  void add_at(double x, double y, double weight, std::span<double> out) const;
};
GroundGrid bake_ground_grid(const scene::Mesh& mesh, const geom::Dome& dome, geom::DomeBasis basis, int samples,
                            double spacing = 0.5, int max_side = 128, const RaytraceOptions& options = {});

// The ground's transfer per layer, vertex-major [vertex · layers + l], steradians:
//     t^g_{v,l} = A_g(n_v) / Σ_k c_k · (1/π) Σ_k c_k V_ground(v, ω_k) B_l(g_k),   c_k = max(0, n_v·ω_k)
// over ground_directions(ground_samples), A_g = unoccluded_ground_transfer: a vertex that sees all
// of the ground it faces, unshadowed, gets A_g A_l(z) / π exactly; one below the ground 0.
std::vector<float> ground_transfer(const scene::Mesh& mesh, std::span<const geom::Plane> planes, const GroundGrid& grid,
                                   int ground_samples, const RaytraceOptions& options = {});

}  // namespace skylit::baker
