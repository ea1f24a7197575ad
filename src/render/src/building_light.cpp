// The light map as the compositor draws it (building_light.hpp).
#include "building_light.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/base/parallel_for.hpp"
#include "skylit/blend/half.hpp"
#include "skylit/render/light_map_kernels.hpp"

namespace skylit::render {
namespace {

// Not finite or negative: 0, as the vertices' transfer (compositor.cpp's layer_major).
std::vector<float> cleaned(std::span<const float> values) {
  std::vector<float> out(values.begin(), values.end());
  for (float& x : out) x = std::isfinite(x) ? std::max(x, 0.0f) : 0.0f;
  return out;
}

// 0, 1, …, n − 1.
std::vector<std::uint32_t> identity(std::size_t n) {
  std::vector<std::uint32_t> out;
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k) out.push_back(static_cast<std::uint32_t>(k));
  return out;
}

// Each channel not finite (or, with `negative_too`, negative) taken as 0 and counted.
Eigen::Vector3d zeroed_where(const Eigen::Vector3d& value, bool negative_too, int* replaced) {
  Eigen::Vector3d out = value;
  for (int c = 0; c < 3; ++c) {
    if (!std::isfinite(out[c]) || (negative_too && out[c] < 0.0)) {
      out[c] = 0.0;
      if (replaced != nullptr) ++*replaced;
    }
  }
  return out;
}

}  // namespace

Eigen::Vector3d finite_or_zero(const Eigen::Vector3d& value, int* replaced) { return zeroed_where(value, false, replaced); }
Eigen::Vector3d finite_nonnegative(const Eigen::Vector3d& value, int* replaced) { return zeroed_where(value, true, replaced); }

std::vector<float> layer_major(std::span<const float> values, std::size_t vertex_count, std::size_t layers) {
  std::vector<float> out(layers * vertex_count, 0.0f);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    for (std::size_t l = 0; l < layers; ++l) {
      const float t = values[v * layers + l];
      out[l * vertex_count + v] = std::isfinite(t) ? std::max(t, 0.0f) : 0.0f;
    }
  }
  return out;
}

std::vector<float> sum_layers(std::span<const float> by_layer, std::size_t vertex_count, std::span<const Eigen::Vector3f> coefficients) {
  std::vector<float> red(vertex_count, 0.0f), green(vertex_count, 0.0f), blue(vertex_count, 0.0f);
  for (std::size_t i = 0; i < coefficients.size(); ++i) {
    const Eigen::Vector3f& c = coefficients[i];
    if (c.isZero(0)) continue;
    const float* t = by_layer.data() + i * vertex_count;
    for (std::size_t v = 0; v < vertex_count; ++v) {
      red[v] += t[v] * c[0];
      green[v] += t[v] * c[1];
      blue[v] += t[v] * c[2];
    }
  }
  std::vector<float> rgb(3 * vertex_count);
  for (std::size_t v = 0; v < vertex_count; ++v) {
    rgb[3 * v] = red[v];
    rgb[3 * v + 1] = green[v];
    rgb[3 * v + 2] = blue[v];
  }
  return rgb;
}

namespace {

// A compressed transfer array of `texels` texels over `charts` charts, `layers` per vector.
bool pca_fits(const bake_format::LightMapComponents& c, std::size_t texels, std::size_t charts, std::size_t layers) {
  const auto k = static_cast<std::size_t>(c.components);
  return layers > 0 && c.layers == layers && c.weights.size() == texels * k && c.vectors.size() == charts * (k + 1) * layers;
}

}  // namespace

void LightMapSums::check(const bake_format::LightMapArrays& arrays, bool ground, const scene::Mesh& mesh, std::size_t layers) {
  const bake_format::LightMapLayout& l = arrays.layout;
  const std::size_t texels = l.texels.size();
  std::string problem;
  if (l.triangle_chart.size() != mesh.triangle_count()) {
    problem = "the light map's " + std::to_string(l.triangle_chart.size()) + " triangles do not fit a model of " +
              std::to_string(mesh.triangle_count());
  } else if (arrays.pca) {
    const bake_format::LightMapPca& p = *arrays.pca;
    if (!pca_fits(p.sky, texels, l.charts.size(), layers) || (ground && !pca_fits(p.ground, texels, l.charts.size(), layers))) {
      problem = "the light map's PCA form does not fit " + std::to_string(texels) + " texels of " + std::to_string(l.charts.size()) +
                " charts × " + std::to_string(layers) + " layers" + (ground ? " (the ground's needed too)" : "");
    }
  } else if (arrays.transfer.size() != texels * layers || (ground && arrays.ground.size() != arrays.transfer.size())) {
    problem = "the light map's " + std::to_string(arrays.transfer.size()) + " transfer values (" + std::to_string(arrays.ground.size()) +
              " of the ground) do not fit " + std::to_string(texels) + " texels × " + std::to_string(layers) + " layers";
  }
  if (!problem.empty()) {
    throw InputError(input_message("manifest.json", -1, -1, "light_map", problem, "re-bake with skylit-bake --light-map, or leave the light map out"));
  }
}

DrawVertices draw_vertices(const scene::Mesh& mesh, const bake_format::LightMapLayout* layout) {
  // The model's vertices keep their indices for the triangles on no chart; a copy per (vertex,
  // chart) follows them.
  DrawVertices out{identity(mesh.vertex_count()), std::vector<Eigen::Vector2f>(mesh.vertex_count(), Eigen::Vector2f(-1.0f, -1.0f)),
                   mesh.indices};
  if (layout == nullptr || layout->texels.empty()) return out;
  if (layout->triangle_chart.size() != mesh.triangle_count()) {
    throw std::invalid_argument("draw_vertices: the light map has " + std::to_string(layout->triangle_chart.size()) +
                                " triangles, the model " + std::to_string(mesh.triangle_count()));
  }
  std::map<std::pair<std::uint32_t, std::int32_t>, std::uint32_t> copies;
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    const std::int32_t chart = layout->triangle_chart[t];
    if (chart < 0) continue;
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.indices[3 * t + k];
      const auto [it, inserted] = copies.try_emplace({v, chart}, static_cast<std::uint32_t>(out.model_vertex.size()));
      if (inserted) {
        out.model_vertex.push_back(v);
        out.atlas.push_back(layout->atlas_coordinates(chart, mesh.positions[v].cast<double>()).cast<float>());
      }
      out.indices[3 * t + k] = it->second;
    }
  }
  return out;
}

std::vector<float> per_draw_vertex(const DrawVertices& draw, std::span<const float> values, int components,
                                   std::span<const float> charted_less) {
  const auto c = static_cast<std::size_t>(components);
  std::vector<float> out(draw.model_vertex.size() * c);
  for (std::size_t d = 0; d < draw.model_vertex.size(); ++d) {
    const std::size_t v = draw.model_vertex[d];
    const bool less = !charted_less.empty() && draw.charted(d);
    for (std::size_t k = 0; k < c; ++k) out[d * c + k] = values[v * c + k] - (less ? charted_less[v * c + k] : 0.0f);
  }
  return out;
}

HeldValues::HeldValues(std::vector<float>&& values, LightMapPrecision precision) {
  if (precision == LightMapPrecision::Float) {
    floats_ = std::move(values);
    return;
  }
  constexpr float kLargestHalf = 65504.0f;
  for (const float v : values) {
    if (std::isfinite(v) && std::abs(v) > kLargestHalf) {
      throw InputError(input_message({}, -1, -1, "render.light_map_precision",
                                     "the light map holds a value (" + std::to_string(v) + ") beyond a half float's ±65504",
                                     "hold it in float (render.light_map_precision: float)"));
    }
  }
  halves_ = std::vector<std::uint16_t>(values.size());
  blend::floats_to_halves(values, halves_);
  values = {};
}

void HeldValues::row_products(std::size_t first, std::size_t n, std::size_t layers, const float* planar, float* out) const {
  if (half()) {
    light_map_kernels::row_products(halves_.data() + first * layers, n, layers, planar, out);
  } else {
    light_map_kernels::row_products(floats_.data() + first * layers, n, layers, planar, out);
  }
}

void HeldValues::texel_sum(std::size_t first, std::size_t K, const float* chart, float* out) const {
  if (half()) {
    light_map_kernels::texel_sum(halves_.data() + first, K, chart, out);
  } else {
    light_map_kernels::texel_sum(floats_.data() + first, K, chart, out);
  }
}

LightMapSums::LightMapSums(bake_format::LightMapArrays&& arrays, bool ground, std::size_t layers, LightMapPrecision precision)
    : texels_(arrays.layout.texels), layers_(layers), width_(arrays.layout.width), height_(arrays.layout.height) {
  const std::size_t count = texels_.size();
  if (arrays.pca) {
    texel_chart_ = bake_format::light_map_texel_charts(arrays.layout);
    const std::size_t charts = arrays.layout.charts.size();
    if (!pca_fits(arrays.pca->sky, count, charts, layers) || (ground && !pca_fits(arrays.pca->ground, count, charts, layers)) ||
        std::find(texel_chart_.begin(), texel_chart_.end(), -1) != texel_chart_.end()) {
      throw std::invalid_argument("LightMapSums: the PCA form does not fit " + std::to_string(count) + " texels of " +
                                  std::to_string(layers) + " layers");
    }
    const auto hold = [&](bake_format::LightMapComponents& c) {
      return Components{c.components, HeldValues(std::move(c.weights), precision), HeldValues(std::move(c.vectors), precision)};
    };
    sky_components_ = hold(arrays.pca->sky);
    if (ground) ground_components_ = hold(arrays.pca->ground);
    arrays.pca.reset();
    return;
  }
  const std::size_t transfer_size = arrays.transfer.size(), ground_size = ground ? arrays.ground.size() : 0;
  if (layers == 0 || transfer_size != count * layers || (ground_size != 0 && ground_size != transfer_size)) {
    throw std::invalid_argument("LightMapSums: " + std::to_string(transfer_size) + " transfer and " + std::to_string(ground_size) +
                                " ground values for " + std::to_string(count) + " texels of " + std::to_string(layers) + " layers");
  }
  transfer_ = HeldValues(cleaned(arrays.transfer), precision);
  if (ground_size != 0) ground_ = HeldValues(cleaned(arrays.ground), precision);
  arrays.transfer = {};
  arrays.ground = {};
}

std::size_t LightMapSums::value_bytes() const {
  return transfer_.bytes() + ground_.bytes() + sky_components_.weights.bytes() + sky_components_.vectors.bytes() +
         ground_components_.weights.bytes() + ground_components_.vectors.bytes();
}

std::vector<float> LightMapSums::sum(std::span<const Eigen::Vector3d> S, std::span<const Eigen::Vector3d> ground_coefficients,
                                     const Eigen::Vector3d& albedo) const {
  Coefficients sky = Coefficients::Zero(static_cast<Eigen::Index>(layers_), 3);
  Coefficients reflected = Coefficients::Zero(static_cast<Eigen::Index>(layers_), 3);
  for (std::size_t l = 0; l < std::min(layers_, S.size()); ++l) {
    for (int c = 0; c < 3; ++c) {
      const double value = S[l][c];  // a corner's or quadratic's may be negative
      sky(static_cast<Eigen::Index>(l), c) = std::isfinite(value) ? static_cast<float>(value) : 0.0f;
    }
  }
  for (std::size_t l = 0; l < std::min(layers_, ground_coefficients.size()); ++l) {
    for (int c = 0; c < 3; ++c) {
      const double value = albedo[c] * ground_coefficients[l][c];
      reflected(static_cast<Eigen::Index>(l), c) = std::isfinite(value) ? static_cast<float>(value) : 0.0f;
    }
  }
  std::vector<float> atlas(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * 4, 0.0f);
  if (!sky_components_.vectors.empty()) {  // the PCA form
    sum_pca(sky, reflected, atlas);
  } else {
    sum_full(sky, reflected, atlas);
  }
  return atlas;
}

void LightMapSums::sum_full(const Coefficients& sky, const Coefficients& reflected, std::vector<float>& atlas) const {
  // E = T S (+ G ρS^g): each texel's row of layers times the three columns, over blocks of texels
  // on every core. Coefficients are column-major: a channel's layers lie together.
  const std::size_t count = texels_.size();
  constexpr std::size_t kBlock = 1024;
  parallel_for(static_cast<int>((count + kBlock - 1) / kBlock), 0, [&](int block) {
    const std::size_t first = static_cast<std::size_t>(block) * kBlock, rows = std::min(count, first + kBlock) - first;
    std::vector<float> E(3 * rows), G(ground_.empty() ? 0 : 3 * rows);
    transfer_.row_products(first, rows, layers_, sky.data(), E.data());
    if (!G.empty()) ground_.row_products(first, rows, layers_, reflected.data(), G.data());
    for (std::size_t k = 0; k < rows; ++k) {
      float* out = atlas.data() + 4 * static_cast<std::size_t>(texels_[first + k]);
      for (std::size_t c = 0; c < 3; ++c) out[c] = E[3 * k + c] + (G.empty() ? 0.0f : G[3 * k + c]);
      out[3] = 1.0f;
    }
  });
}

void LightMapSums::sum_pca(const Coefficients& sky, const Coefficients& reflected, std::vector<float>& atlas) const {
  // Per chart its K + 1 vectors times S (over blocks of the charts' rows, on every core), then per
  // texel K multiply-adds per channel against its chart's sums, held planar: μ·S per channel,
  // then p_k·S for every k, one channel after another.
  const auto per_chart = [&](const Components& c, const Coefficients& coefficients) {
    const std::size_t rows = c.vectors.size() / layers_, K = static_cast<std::size_t>(c.components);
    std::vector<float> by_row(3 * rows);
    constexpr std::size_t kRows = 256;
    parallel_for(static_cast<int>((rows + kRows - 1) / kRows), 0, [&](int block) {
      const std::size_t first = static_cast<std::size_t>(block) * kRows, n = std::min(rows, first + kRows) - first;
      c.vectors.row_products(first, n, layers_, coefficients.data(), by_row.data() + 3 * first);
    });
    std::vector<float> planar(by_row.size());
    for (std::size_t chart = 0; chart < rows / (K + 1); ++chart) {
      const float* from = by_row.data() + chart * (K + 1) * 3;
      float* to = planar.data() + chart * (K + 1) * 3;
      for (std::size_t ch = 0; ch < 3; ++ch) {
        to[ch] = from[ch];
        for (std::size_t k = 0; k < K; ++k) to[3 + ch * K + k] = from[3 * (k + 1) + ch];
      }
    }
    return planar;
  };
  const bool ground = ground_components_.components > 0;
  const std::vector<float> sky_sums = per_chart(sky_components_, sky);
  const std::vector<float> ground_sums = ground ? per_chart(ground_components_, reflected) : std::vector<float>();
  const auto sky_k = static_cast<std::size_t>(sky_components_.components);
  const auto ground_k = static_cast<std::size_t>(ground_components_.components);
  const std::size_t count = texels_.size();
  constexpr std::size_t kBlock = 4096;
  parallel_for(static_cast<int>((count + kBlock - 1) / kBlock), 0, [&](int block) {
    const std::size_t first = static_cast<std::size_t>(block) * kBlock, last = std::min(count, first + kBlock);
    for (std::size_t x = first; x < last; ++x) {
      float* out = atlas.data() + 4 * static_cast<std::size_t>(texels_[x]);
      const auto chart = static_cast<std::size_t>(texel_chart_[x]);
      sky_components_.weights.texel_sum(x * sky_k, sky_k, sky_sums.data() + chart * (sky_k + 1) * 3, out);
      if (ground) ground_components_.weights.texel_sum(x * ground_k, ground_k, ground_sums.data() + chart * (ground_k + 1) * 3, out);
      out[3] = 1.0f;
    }
  });
}

}  // namespace skylit::render
