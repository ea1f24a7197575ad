#pragma once
// The building's light map (docs/bake-format.md, "The light map"): the model's large flat regions
// laid out as charts in one atlas of square texels, each texel a point on its region whose
// transfer the bake traced as it traces a vertex's. Where a triangle lies on a chart the
// compositor takes the sky's and the ground's light from the atlas (bilinear between texel
// centres) instead of interpolating it between the triangle's corners.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/manifest.hpp"

namespace skylit::bake_format {

// A chart: width × height texels of texel_u × texel_v metres at atlas column x, row y; texel
// (i, j) of it is centred at origin + i texel_u u + j texel_v v, u and v unit and in its region's
// plane (u × v its normal).
struct LightMapChart {
  int x = 0, y = 0, width = 0, height = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX(), v = Eigen::Vector3d::UnitY();
  double texel_u = 0.0, texel_v = 0.0;
};

struct LightMapLayout {
  double texel = 0.0;                          // metres: the charts' (finer across a narrow chart)
  int width = 0, height = 0;                   // the atlas, texels
  std::vector<LightMapChart> charts;
  std::vector<std::int32_t> triangle_chart;    // per triangle of the model as baked; −1: none
  std::vector<std::uint32_t> texels;           // the traced texels' atlas indices (row × width + column), ascending

  // Where p (on the chart's plane) falls in the atlas, in texels: texel (c, r)'s centre at
  // (c + ½, r + ½), as GL's texture coordinates times the atlas size.
  Eigen::Vector2d atlas_coordinates(int chart, const Eigen::Vector3d& p) const;
};

// The value at atlas coordinates `a` (LightMapLayout::atlas_coordinates) as GL's linear filter
// reads it: bilinear between the four nearest texel centres, clamped to the atlas's edges.
// `atlas`: one RGB value per atlas texel, rows of `width`.
Eigen::Vector3d sample_light_map(std::span<const Eigen::Vector3d> atlas, int width, int height, const Eigen::Vector2d& a);

// Per traced texel values (texel-major, `layers` each, as the light map's transfer) summed with
// S into an atlas of RGB values (texels that were not traced stay 0):
//     E(texel) = Σ_l S_l t_{texel,l}
// values not finite or negative count as 0, as the compositor's sum.
std::vector<Eigen::Vector3d> light_map_atlas(const LightMapLayout& layout, std::span<const float> transfer,
                                             std::span<const Eigen::Vector3d> S);

// The layout's three files in bake_dir (record's names): charts float32 [charts, 15] (x, y,
// width, height, origin, u, v, texel_u, texel_v), triangles uint32 [triangles] (0xFFFFFFFF: none), texels uint32
// [texels].
void write_light_map_layout(const std::filesystem::path& bake_dir, const Manifest::LightMap& record, const LightMapLayout& layout);
// Reads and checks them against the manifest: InputError naming the file and what is wrong
// (a chart outside the atlas, a triangle's chart out of range, texels out of order).
LightMapLayout read_light_map_layout(const std::filesystem::path& bake_dir, const Manifest& manifest);

// The bake's light map whole: its layout and its texels' transfer, and the ground's with a ground
// layer (else empty). InputError as read_light_map_layout and read_npy.
struct LightMapArrays {
  LightMapLayout layout;
  std::vector<float> transfer, ground;
};
LightMapArrays read_light_map(const std::filesystem::path& bake_dir, const Manifest& manifest);

}  // namespace skylit::bake_format
