#pragma once
// The building's light map (docs/baker.md, "A light map on the flat faces"): the model's flat
// regions of at least min_area laid out as charts of square texels in one atlas, and the point
// each texel stands for, which the bake traces as it traces a vertex.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/light_map.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::baker {

struct LightMapOptions {
  double texel = 0.1;     // metres per texel
  double min_area = 0.1;  // m²: a smaller flat region stays with its vertices
  // A chart narrower than this many texels (a beam's side, a column's facet) takes finer texels,
  // as many across its narrower side, down to a quarter of `texel`; 0: every chart the same.
  // (The defaults are what bench/RESULTS.md, "A light map on the flat faces", found best.)
  int min_across = 10;
};
// InputError naming the option (--light-map, --light-map-min-area, --light-map-min-across) for
// values out of range.
void validate_light_map_options(const LightMapOptions& options);

struct LightMapPoints {
  bake_format::LightMapLayout layout;
  std::vector<Eigen::Vector3f> positions;  // per traced texel (layout.texels' order)
  std::vector<Eigen::Vector3f> normals;    // its triangle's face normal
};
// Its texels keep their points on the region's triangles: a texel whose centre falls outside (at
// the region's edge, where a bilinear lookup from inside still reads it) takes the region's point
// nearest its centre, moved a little into its triangle, so that it sees what the faces at the
// edge see and not what lies past it (the part the wall meets, the inside of a column).
// Deterministic (every shard and a merge lay it out alike). InputError when the atlas would exceed
// 16384 texels along a side (a texel too fine for the model).
LightMapPoints lay_out_light_map(const scene::Mesh& mesh, const LightMapOptions& options);

// Texels whose row of `values` (texel-major, `layers` each) is all zero, and all zero in `also`
// (the same shape; empty: not consulted), saw nothing: they lie inside another part, where no one
// looks, but a lookup from the visible faces beside them still reads them. Each takes the mean
// of its chart's neighbours (8-connected) that saw something, in up to `rounds` passes; in both
// arrays.
void fill_unseen_texels(const bake_format::LightMapLayout& layout, std::size_t layers, std::vector<float>& values,
                        std::vector<float>* also, int rounds = 4);

}  // namespace skylit::baker
