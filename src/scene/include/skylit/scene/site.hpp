#pragma once
// The site description: a YAML file (the schema is a contract, see docs/site-format.md).
//   scene:  {model: models/gate.glb, up: z|y, scale: 1.0, max_edge: 0}
//   dome:   {frequency: 2, basis: faces|corners}
//   location: {latitude: 34.69, longitude: 135.80}     (optional)
//   planes: [{name, origin: [x,y,z], u: [..], v: [..], resolution: [W, H], surface}, ...]
#include <cstdint>
#include <filesystem>
#include <span>
#include <utility>
#include <optional>
#include <string>
#include <vector>

#include "skylit/geom/dome_basis.hpp"
#include "skylit/geom/plane.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::scene {

inline constexpr int kMaxPlaneResolution = 16384;

// What a shadowing plane stands for (`surface` in the site file). A real surface is seen by the
// HMD camera (the real ground): the compositor multiplies the camera's pixels by T there. A
// virtual one lies on the virtual building (a wall, a roof): T shades the building there.
enum class PlaneSurface { Virtual, Real };

// Where on Earth the site is (`location` in the site file): the sun's expected place for a sky
// frame's time, against which the console checks the sky camera's aim.
struct GeoLocation {
  double latitude_deg = 0;   // north, [-90, 90]
  double longitude_deg = 0;  // east, [-180, 180]
};

struct Site {
  std::filesystem::path file;    // the YAML it came from
  std::filesystem::path model;   // resolved against the YAML's directory, and inside its root
  // `root`, optional: the folder the files the YAML names must lie in (empty: the YAML's folder).
  std::filesystem::path root;
  UpAxis up = UpAxis::Z;         // default z for OBJ, y for glTF when `up` is absent
  double scale = 1.0;
  // `scene.max_edge`, metres, optional: triangles are split until no edge is longer (0: as
  // modelled). The building's light is per vertex; a large face with vertices only where it
  // meets other parts shows their light across its middle (bench/RESULTS.md, "Inside the
  // triangles"). The bake and the live service load the model alike (load_site_model).
  double max_edge = 0.0;
  int dome_frequency = 2;
  geom::DomeBasis dome_basis = geom::DomeBasis::Faces;  // `dome.basis`, optional
  std::optional<GeoLocation> location;                  // `location`, optional
  std::vector<geom::Plane> planes;
  // One per plane, in the same order. A Site built in code may leave it shorter: the planes
  // without an entry are Virtual, as in a file without `surface`.
  std::vector<PlaneSurface> plane_surfaces;

  PlaneSurface surface_of(std::size_t plane) const {
    return plane < plane_surfaces.size() ? plane_surfaces[plane] : PlaneSurface::Virtual;
  }
};

// Parses and validates a site file. Any problem (missing or mistyped field, unknown field, odd
// or zero frequency, resolution 0 or over 16384, degenerate or non-finite plane, duplicate plane
// names) throws InputError with file, line, column, field and fix. The model is not loaded.
Site load_site(const std::filesystem::path& file);

// Writes a site back as YAML (for tools and tests that produce sites).
std::string site_to_yaml(const Site& site);

// The site's model as every program uses it: load_model with the site's up axis and scale, then
// split to scene.max_edge (subdivide). The bake's per-vertex data follow this mesh.
Mesh load_site_model(const Site& site);

// Splits every triangle with an edge longer than max_edge (metres, > 0) at its edges' midpoints
// (one into four, again until none is longer), each new vertex shared by the triangles on its
// edge, its normal and texture coordinates interpolated; vertices already there keep their
// order, and the new ones follow. max_edge <= 0 or not finite: the mesh unchanged.
void subdivide(Mesh& mesh, double max_edge);

// An edge of a mesh, by its two vertex indices (smaller first).
using Edge = std::pair<std::uint32_t, std::uint32_t>;

// One round of conforming refinement where the light changes (the bake decides which edges,
// baker/refine.hpp): every marked edge gets its midpoint (position, normal and texture
// coordinates interpolated, shared by the triangles on the edge). A triangle with two marked
// edges gets its third marked too, so that each is either halved (one marked edge, through the
// opposite corner) or split in four (three), and edges with the same ends in space (a crease
// where each face has its own vertices) are split together: no vertex is left hanging on a
// neighbour's edge.
// Returns the edges split, closure included, sorted: the new vertices follow the old in that
// order. Marked pairs that are no edge of the mesh throw std::invalid_argument.
std::vector<Edge> split_edges(Mesh& mesh, std::span<const Edge> marked);

// The edges split in each round, as a bake records them (bake_format, "refinement").
struct Refinement {
  std::vector<std::vector<Edge>> rounds;
  std::size_t split_count() const;
};

// Replays a recorded refinement on the model it was made on: split_edges round by round. A round
// whose edges are not the mesh's, or not closed as split_edges closes them, throws
// std::invalid_argument (the model is not the one refined).
void apply_refinement(Mesh& mesh, const Refinement& refinement);

}  // namespace skylit::scene
