#pragma once
// Where the bake splits the model (docs/baker.md, "Refining the model where the light changes"):
// the live service interpolates each vertex's light across its triangles, so an edge whose
// midpoint sees the sky and the ground differently from its ends gets a vertex there.
#include <cstdio>
#include <span>

#include "skylit/baker/visibility.hpp"
#include "skylit/scene/site.hpp"

namespace skylit::baker {

struct RefineOptions {
  // Split where a point's light differs from what its corners interpolate by more than this
  // share of a uniform sky's horizontal irradiance (π), for any sky of radiance at most 1 over a
  // ground of radiance `ground_albedo`: Σ_k |Δ(c_k V_k L_k)| · 4π/K / π. 0: no refinement.
  double tolerance = 0.0;
  int rounds = 4;             // at most this many rounds of splits
  double min_edge = 0.25;     // metres: an edge shorter than twice this is not split for its own sake
  int directions = 256;       // over the whole sphere (a Fibonacci lattice), per point
  double ground_albedo = 0.2;
  int threads = 0;            // 0: all cores
};

// Is `options` usable? An InputError naming skylit-bake's option and the fix otherwise.
void validate_refine_options(const RefineOptions& options);

// The directions every point is seen along: `count` of equal solid angle over the sphere.
std::vector<Vec3> sphere_directions(int count);

// Rounds of: each edge of the mesh at least 2 · min_edge long is tested at its midpoint, and each
// triangle at its centroid (whose failure marks all its long enough edges); the marked edges are
// split (scene::split_edges). Points that see nothing at all (inside another part: a plinth's top
// under its column) mark nothing. Stops after `rounds` or when nothing is marked. `mesh` ends
// refined; the refinement replays it on the unrefined model (scene::apply_refinement). One line
// per round on `log` (null: none).
scene::Refinement refine_where_light_changes(scene::Mesh& mesh, std::span<const geom::Plane> planes,
                                             const RefineOptions& options, std::FILE* log = nullptr);

}  // namespace skylit::baker
