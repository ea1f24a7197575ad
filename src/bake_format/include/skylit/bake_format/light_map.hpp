#pragma once
// The building's light map (docs/bake-format.md, "The light map"): the model's large flat regions
// laid out as charts in one atlas of texels, each a point on its region traced as a vertex is.
// Where a triangle lies on a chart the compositor takes the sky's and the ground's light from the
// atlas (bilinear between texel centres), not from its corners. Its PCA form holds the transfer
// compressed chart by chart.
#include <cstdint>
#include <filesystem>
#include <optional>
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

// How the compositor takes a light map's transfer values: the full form's t (not finite or
// negative: 0), or the PCA form's t̂ as they are (a fit may dip below 0; not finite: 0), its sum
// then clamped at 0.
enum class LightMapValues { Full, Reconstructed };

// Per traced texel values (texel-major, `layers` each, as the light map's transfer) summed with
// S into an atlas of RGB values (texels that were not traced stay 0):
//     E(texel) = Σ_l S_l t_{texel,l}
// taken as the compositor takes them (LightMapValues).
std::vector<Eigen::Vector3d> light_map_atlas(const LightMapLayout& layout, std::span<const float> transfer,
                                             std::span<const Eigen::Vector3d> S, LightMapValues values = LightMapValues::Full);

// The layout's three files in bake_dir (record's names): charts float32 [charts, 15] (x, y,
// width, height, origin, u, v, texel_u, texel_v), triangles uint32 [triangles] (0xFFFFFFFF: none), texels uint32
// [texels].
void write_light_map_layout(const std::filesystem::path& bake_dir, const Manifest::LightMap& record, const LightMapLayout& layout);
// Reads and checks them against the manifest: InputError naming the file and what is wrong
// (a chart outside the atlas, a triangle's chart out of range, texels out of order).
LightMapLayout read_light_map_layout(const std::filesystem::path& bake_dir, const Manifest& manifest);

// ---- The PCA form (docs/bake-format.md, "The light map's PCA form"; light_map_pca.cpp) ----
//
// The texels of one chart lie on one plane, facing one way, so their transfer vectors differ only
// in what the model hides from each: a few components per chart hold them (a wall's shadow edge
// moves across it smoothly). For texel x of chart c
//
//   t̂_x = μ_c + Σ_k a_{x,k} p_{c,k}         E_x = μ_c·S + Σ_k a_{x,k} (p_{c,k}·S)
//
// μ_c the chart's mean transfer, p_{c,k} its components (the projections of its texels onto the
// leading left singular vectors a_{·,k}, unit over the chart's texels), so that t̂ is the best
// rank-K fit of the chart's centred transfer in the prior's weighted norm.
struct LightMapPcaOptions {
  int components = 32;  // K per chart, >= 1 (a chart of fewer texels keeps as many as it has)
  // A sky prior (PcaOptions::sky_correlation_deg) for the sky's transfer: the fit weighted for
  // skies whose radiance is correlated over this angle. 0 (the default): every layer alike,
  // which on park (a low sun, its aureole left in the layers) was the better fit at every K
  // (bench/RESULTS.md). The ground's layers carry the separated sources' light on the ground,
  // one face's spike, so the ground's transfer is always fitted with every layer alike.
  double sky_correlation_deg = 0.0;
  // The bake keeps the full form beside it (skylit-bake compress can then fit another K), or
  // leaves it out (--light-map-pca-only): the full form is 480 floats per texel, most of a bake.
  bool keep_full_form = true;
};
// std::invalid_argument naming the field.
void check_light_map_pca_options(const LightMapPcaOptions& options);

// One texel-major transfer array of the light map (the sky's or the ground's), compressed.
struct LightMapComponents {
  int components = 0;            // K (0: none)
  std::size_t layers = 0;
  std::vector<float> weights;    // [texels, K]: a_{x,k}
  std::vector<float> vectors;    // [charts, K + 1, layers]: μ_c, then p_{c,1} … p_{c,K}
  // |t − t̂| over every texel and layer, in the transfer's units (steradians); for scale, the
  // RMS of t itself.
  double rms_error = 0.0;
  double max_error = 0.0;
  double rms_value = 0.0;
};

// The chart whose rectangle holds each traced texel (layout.texels order).
std::vector<std::int32_t> light_map_texel_charts(const LightMapLayout& layout);

// `transfer`: texel-major, `layers` per texel (light_map_transfer.npy or light_map_ground.npy);
// values not finite or negative count as 0, as the compositor's sum. `directions`: per layer, unit
// (its face's centre), needed when sky_correlation_deg > 0. std::invalid_argument for sizes that
// do not fit or bad options.
LightMapComponents compress_light_map(const LightMapLayout& layout, std::span<const float> transfer, std::size_t layers,
                                      const LightMapPcaOptions& options, std::span<const Vec3> directions = {});

// t̂, texel-major as the full form (what the compositor's sum of this form equals).
std::vector<float> expand_light_map(const LightMapLayout& layout, const LightMapComponents& components);

// The bake's PCA form of its light map: the sky's, and the ground's with a ground layer.
struct LightMapPca {
  LightMapComponents sky, ground;
};
// Writes the form's files (record.light_map->pca's names) into bake_dir.
void write_light_map_pca(const std::filesystem::path& bake_dir, const Manifest::LightMap::Pca& record, const LightMapPca& pca);
// Reads them and checks them against the manifest and the layout: InputError naming the file.
LightMapPca read_light_map_pca(const std::filesystem::path& bake_dir, const Manifest& manifest, const LightMapLayout& layout);

// ---- The bake's light map whole ----
//
// Its layout, and either its texels' transfer and the ground's with a ground layer (else empty),
// the full form, or its PCA form (then transfer and ground are empty).
enum class LightMapForm { Full, Pca };
struct LightMapArrays {
  LightMapLayout layout;
  std::vector<float> transfer, ground;
  std::optional<LightMapPca> pca;
};
// The PCA form where the bake has one, else the full.
LightMapForm smallest_light_map_form(const Manifest& manifest);
// InputError as read_light_map_layout and read_npy, and for the PCA form of a bake without one.
LightMapArrays read_light_map(const std::filesystem::path& bake_dir, const Manifest& manifest, LightMapForm form = LightMapForm::Full);

}  // namespace skylit::bake_format
