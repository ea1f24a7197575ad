#pragma once
// Virtual planes on the model's large flat faces where its vertices cannot carry the light
// (docs/baker.md, "Planes where the vertices cannot carry the light"): the compositor takes a
// covered fragment's light from the plane's texels instead of interpolating it between vertices.
#include <cstdio>
#include <filesystem>
#include <span>
#include <vector>

#include "skylit/baker/refine.hpp"
#include "skylit/geom/plane.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

struct WallPlaneOptions {
  int count = 4;             // planes to propose at most
  double texel = 0.05;       // metres per texel
  double min_area = 2.0;     // m²: a smaller flat region stays with its vertices
  // A region whose vertices interpolate its sky's light within this needs no plane: RMS by area
  // and over test skies (clear skies, the sun 10°, 30° and 60° up every 45°, and an overcast one;
  // the sun's own term is per pixel already), a share of each sky's horizontal irradiance.
  double min_error = 0.02;
  double offset = 0.01;      // metres: the plane lies this far in front of the surface
  int max_resolution = 1024; // texels along a side at most (the texel grows beyond)
  int directions = 256;      // seen along, per point (sphere_directions)
  int threads = 0;           // 0: all cores
  // The model as the bake will see it: refined (skylit-bake --refine) and its vertices fitted
  // (--vertex-fit N) before the vertices' error is measured.
  RefineOptions refine;
  int vertex_fit = 0;
};

struct WallPlane {
  geom::Plane plane;          // named wall-auto-N, its normal the faces' own
  double area = 0.0;          // m² of the model's faces it covers
  std::size_t triangles = 0;
  double error = 0.0;         // the vertices' error inside those faces (WallPlaneOptions::min_error's measure)
};

// What find_wall_planes measured, for a picture: the model as it measured it (refined), and per
// triangle its flat region's error (WallPlaneOptions::min_error's measure; NaN where a region was
// not measured: smaller than min_area, or covered by a virtual plane) and the plane proposed over
// it (its index in find_wall_planes' result; −1: none).
struct WallErrorMap {
  scene::Mesh mesh;
  std::vector<double> error;
  std::vector<int> plane;
};

// The model's flat regions (of the refined model with options.refine; triangles joined across shared edges, normals within 1°, in one plane
// within 1 cm) of at least min_area, not already covered by one of `virtual_planes` (the
// compositor's rule: within 5 cm, normals within 15°), whose vertices' error at four points per
// triangle is at least min_error (its measure); the `count` with the largest squared error × area, each with a
// plane over its rectangle. `planes`: every plane of the site (rays pass through them as the
// bake's do). InputError for options out of range.
// A line on `log` (null: none) before the tracing, which takes the time on a large model; what
// was measured in `map` (null: not kept).
std::vector<WallPlane> find_wall_planes(const scene::Mesh& mesh, std::span<const geom::Plane> planes,
                                        std::span<const geom::Plane> virtual_planes, const WallPlaneOptions& options,
                                        std::FILE* log = nullptr, WallErrorMap* map = nullptr);

// A picture of the map (baker::write_vertex_picture's view): each flat region coloured by its
// vertices' error, dark blue at 0 through yellow to red at 2 × min_error and beyond, faded where
// no plane was proposed over it; grey where not measured. PNG, written atomically.
void write_wall_picture(const std::filesystem::path& file, const WallErrorMap& map, double min_error);

// skylit-bake walls: the site at site_file with find_wall_planes' planes added as virtual planes
// (as many as the compositor's 8 leave room for), written to out_file (the model's path made
// relative to it), and write_wall_picture's picture beside it (out_file with .png); a table of
// what was found on `log` (null: none). InputError when out_file is
// the site itself or the site has no room for another virtual plane.
std::vector<WallPlane> add_wall_planes(const std::filesystem::path& site_file, const std::filesystem::path& out_file,
                                       WallPlaneOptions options, std::FILE* log);

}  // namespace skylit::baker
