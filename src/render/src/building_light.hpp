#pragma once
// The building's light as the compositor sums it on the CPU when the sky changes: per vertex from
// the transfer vectors, and per texel of the bake's light map (bake_format/light_map.hpp), with
// the model's vertices split where triangles on different charts (or on none) meet, each corner
// with its chart's atlas coordinates.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include "skylit/bake_format/light_map.hpp"
#include "skylit/render/building_irradiance.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::render {

// `value` with each channel that is not finite (finite_nonnegative: or negative) taken as 0,
// counted in *replaced (when not null).
Eigen::Vector3d finite_or_zero(const Eigen::Vector3d& value, int* replaced);
Eigen::Vector3d finite_nonnegative(const Eigen::Vector3d& value, int* replaced);

// Vertex-major values (a bake's transfer arrays: `layers` per vertex) layer after layer, so that
// a sum runs over every vertex of a layer at once; not finite or negative: 0.
std::vector<float> layer_major(std::span<const float> values, std::size_t vertex_count, std::size_t layers);

// Σ_l c_l t_{v,l} per vertex, RGB (rgb[3v + k]), in float, layer after layer, from layer-major t;
// a layer whose coefficient is zero is skipped.
std::vector<float> sum_layers(std::span<const float> by_layer, std::size_t vertex_count, std::span<const Eigen::Vector3f> coefficients);

// The building's vertices as drawn: a model vertex once per chart its triangles lie on (and once
// for the triangles on none), each with its atlas coordinates (LightMapLayout::atlas_coordinates;
// (−1, −1) on none), and the model's triangles over them. Without a layout: the model's own.
struct DrawVertices {
  std::vector<std::uint32_t> model_vertex;
  std::vector<Eigen::Vector2f> atlas;
  std::vector<std::uint32_t> indices;
  bool charted(std::size_t draw_vertex) const { return atlas[draw_vertex].x() >= 0.0f; }
};
DrawVertices draw_vertices(const scene::Mesh& mesh, const bake_format::LightMapLayout* layout);

// `values` (`components` per model vertex) per draw vertex; a charted one takes its value less
// `charted_less`'s (the same shape; empty: nothing less), the share the light map carries there.
std::vector<float> per_draw_vertex(const DrawVertices& draw, std::span<const float> values, int components,
                                   std::span<const float> charted_less = {});

// Values held in float or in IEEE half floats (LightMapPrecision), read in blocks as floats.
class HeldValues {
 public:
  HeldValues() = default;
  // Half: InputError (render.light_map_precision) when a finite value lies beyond ±65504.
  HeldValues(std::vector<float>&& values, LightMapPrecision precision);
  std::size_t size() const { return floats_.size() + halves_.size(); }
  bool empty() const { return size() == 0; }
  bool half() const { return !halves_.empty(); }
  std::size_t bytes() const { return floats_.size() * sizeof(float) + halves_.size() * sizeof(std::uint16_t); }
  // out[3r + c] = Σ_l value[(first + r) · layers + l] · planar[c · layers + l] for r in [0, n):
  // rows of `layers` values times three coefficient columns (light_map_kernels.hpp).
  void row_products(std::size_t first, std::size_t n, std::size_t layers, const float* planar, float* out) const;
  // out[c] += chart[c] + Σ_k value[first + k] · chart[3 + c · K + k] (light_map_kernels.hpp).
  void texel_sum(std::size_t first, std::size_t K, const float* chart, float* out) const;

 private:
  std::vector<float> floats_;
  std::vector<std::uint16_t> halves_;
};

// The light map's sums on the CPU (no GL: any thread may sum while another draws).
class LightMapSums {
 public:
  // The options' light map (either form) checked against the model and the bake (InputError naming
  // the fix); `ground`: the ground's light is on (its transfer then needed too).
  static void check(const bake_format::LightMapArrays& arrays, bool ground, const scene::Mesh& mesh, std::size_t layers);
  // The full form: transfer and ground (empty: none) texel-major, `layers` per texel; or the PCA
  // form when arrays.pca holds it (its ground's with `ground`). Moves the arrays' values in, held
  // at `precision`. std::invalid_argument when the sizes do not fit.
  LightMapSums(bake_format::LightMapArrays&& arrays, bool ground, std::size_t layers,
               LightMapPrecision precision = LightMapPrecision::Float);

  // E = Σ_l S_l t_l + ρ ⊙ Σ_l S^g_l t^g_l per texel: RGBA (alpha 1 on the charts' texels, 0
  // elsewhere), the atlas's size, row-major; S as given (not finite: 0), E not clamped. The full
  // form: values not finite or negative count as 0, as at the vertices. The PCA form: per chart
  // the K + 1 sums μ_c·S, p_{c,k}·S, then per texel μ_c·S + Σ_k a_{x,k} p_{c,k}·S, which is the
  // same sum over t̂. Half floats are read as the floats they hold. Const: several may run at once.
  std::vector<float> sum(std::span<const Eigen::Vector3d> S, std::span<const Eigen::Vector3d> ground_coefficients,
                         const Eigen::Vector3d& albedo) const;

  // The bytes its values hold (transfer or components, the ground's with them).
  std::size_t value_bytes() const;

 private:
  using Coefficients = Eigen::Matrix<float, Eigen::Dynamic, 3>;
  struct Components {  // bake_format::LightMapComponents as held
    int components = 0;
    HeldValues weights, vectors;
  };
  void sum_full(const Coefficients& sky, const Coefficients& reflected, std::vector<float>& atlas) const;
  void sum_pca(const Coefficients& sky, const Coefficients& reflected, std::vector<float>& atlas) const;

  std::vector<std::uint32_t> texels_;
  HeldValues transfer_, ground_;
  Components sky_components_, ground_components_;  // the PCA form's (the ground's with the ground on); none: the full form
  std::vector<std::int32_t> texel_chart_;  // the PCA form's chart per texel
  std::size_t layers_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace skylit::render
