// The building's light map: its layout's files, and reading values from it (light_map.hpp).
#include "skylit/bake_format/light_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/base/error.hpp"

namespace skylit::bake_format {
namespace fs = std::filesystem;

namespace {

constexpr std::uint32_t kNoLightMapChart = std::numeric_limits<std::uint32_t>::max();
constexpr int kLightMapChartColumns = 15;

[[noreturn]] void bad_light_map(const fs::path& file, const std::string& field, const std::string& problem) {
  throw InputError(input_message(file, -1, -1, field, problem, "re-bake with skylit-bake --light-map"));
}

}  // namespace

Eigen::Vector2d LightMapLayout::atlas_coordinates(int chart, const Eigen::Vector3d& p) const {
  const LightMapChart& c = charts.at(static_cast<std::size_t>(chart));
  const Eigen::Vector3d d = p - c.origin;
  return {c.x + 0.5 + d.dot(c.u) / c.texel_u, c.y + 0.5 + d.dot(c.v) / c.texel_v};
}

Eigen::Vector3d sample_light_map(std::span<const Eigen::Vector3d> atlas, int width, int height, const Eigen::Vector2d& a) {
  const double x = a.x() - 0.5, y = a.y() - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double wx = x - fx, wy = y - fy;
  const auto at = [&](double column, double row) -> Eigen::Vector3d {
    const auto c = static_cast<std::size_t>(std::clamp(column, 0.0, static_cast<double>(width - 1)));
    const auto r = static_cast<std::size_t>(std::clamp(row, 0.0, static_cast<double>(height - 1)));
    return atlas[r * static_cast<std::size_t>(width) + c];
  };
  return (1.0 - wy) * ((1.0 - wx) * at(fx, fy) + wx * at(fx + 1.0, fy)) + wy * ((1.0 - wx) * at(fx, fy + 1.0) + wx * at(fx + 1.0, fy + 1.0));
}

std::vector<Eigen::Vector3d> light_map_atlas(const LightMapLayout& layout, std::span<const float> transfer,
                                             std::span<const Eigen::Vector3d> S, LightMapValues values) {
  const bool reconstructed = values == LightMapValues::Reconstructed;
  const std::size_t layers = S.size();
  if (layers == 0 || transfer.size() != layout.texels.size() * layers) {
    throw std::invalid_argument("light_map_atlas: " + std::to_string(transfer.size()) + " transfer values for " +
                                std::to_string(layout.texels.size()) + " texels of " + std::to_string(layers) + " layers");
  }
  std::vector<Eigen::Vector3d> atlas(static_cast<std::size_t>(layout.width) * static_cast<std::size_t>(layout.height),
                                     Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < layout.texels.size(); ++k) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    const float* t = transfer.data() + k * layers;
    for (std::size_t l = 0; l < layers; ++l) {
      if (std::isfinite(t[l]) && (reconstructed || t[l] > 0.0f)) sum += static_cast<double>(t[l]) * S[l];
    }
    atlas.at(layout.texels[k]) = reconstructed ? sum.cwiseMax(0.0) : sum;
  }
  return atlas;
}

void write_light_map_layout(const fs::path& bake_dir, const Manifest::LightMap& record, const LightMapLayout& layout) {
  std::vector<float> charts;
  charts.reserve(layout.charts.size() * kLightMapChartColumns);
  for (const LightMapChart& c : layout.charts) {
    charts.insert(charts.end(), {static_cast<float>(c.x), static_cast<float>(c.y), static_cast<float>(c.width), static_cast<float>(c.height)});
    for (const Eigen::Vector3d* w : {&c.origin, &c.u, &c.v}) {
      for (int k = 0; k < 3; ++k) charts.push_back(static_cast<float>((*w)[k]));
    }
    charts.push_back(static_cast<float>(c.texel_u));
    charts.push_back(static_cast<float>(c.texel_v));
  }
  const std::size_t chart_shape[] = {layout.charts.size(), kLightMapChartColumns};
  write_npy(bake_dir / record.charts_file, charts, chart_shape);
  std::vector<std::uint32_t> triangles(layout.triangle_chart.size());
  std::transform(layout.triangle_chart.begin(), layout.triangle_chart.end(), triangles.begin(),
                 [](std::int32_t c) { return c < 0 ? kNoLightMapChart : static_cast<std::uint32_t>(c); });
  const std::size_t triangle_shape[] = {triangles.size()};
  write_npy_u32(bake_dir / record.triangles_file, triangles, triangle_shape);
  const std::size_t texel_shape[] = {layout.texels.size()};
  write_npy_u32(bake_dir / record.texels_file, layout.texels, texel_shape);
}

LightMapLayout read_light_map_layout(const fs::path& bake_dir, const Manifest& manifest) {
  if (!manifest.light_map) throw InputError(bake_dir.string() + ": the bake has no light map. Fix: re-bake with skylit-bake --light-map 0.1");
  const Manifest::LightMap& record = *manifest.light_map;
  LightMapLayout layout;
  layout.texel = manifest.plan.light_map.texel;
  layout.width = record.width;
  layout.height = record.height;
  std::vector<std::size_t> shape;
  const fs::path charts_file = bake_dir / record.charts_file;
  const std::vector<float> charts = read_npy(charts_file, &shape);
  if (shape.size() != 2 || shape[1] != kLightMapChartColumns || shape[0] != record.chart_count) {
    bad_light_map(charts_file, "shape", "must be [" + std::to_string(record.chart_count) + ", 15]");
  }
  for (std::size_t i = 0; i < record.chart_count; ++i) {
    const float* row = charts.data() + i * kLightMapChartColumns;
    LightMapChart c;
    c.x = static_cast<int>(row[0]), c.y = static_cast<int>(row[1]), c.width = static_cast<int>(row[2]), c.height = static_cast<int>(row[3]);
    c.origin = Eigen::Vector3f(row[4], row[5], row[6]).cast<double>();
    c.u = Eigen::Vector3f(row[7], row[8], row[9]).cast<double>();
    c.v = Eigen::Vector3f(row[10], row[11], row[12]).cast<double>();
    c.texel_u = row[13];
    c.texel_v = row[14];
    for (const double texel : {c.texel_u, c.texel_v}) {
      if (!(texel > 0.0) || !(texel <= layout.texel * (1.0 + 1e-6))) {
        bad_light_map(charts_file, "chart " + std::to_string(i), "has a texel of " + std::to_string(texel) + " m, not in (0, " +
                                                                       std::to_string(layout.texel) + "] (plan.light_map.texel)");
      }
    }
    if (c.x < 0 || c.y < 0 || c.width < 1 || c.height < 1 || c.x + c.width > layout.width || c.y + c.height > layout.height ||
        !c.origin.allFinite() || std::abs(c.u.norm() - 1.0) > 1e-3 || std::abs(c.v.norm() - 1.0) > 1e-3) {
      bad_light_map(charts_file, "chart " + std::to_string(i), "lies outside the " + std::to_string(layout.width) + "×" +
                                                          std::to_string(layout.height) + " atlas or has axes that are not unit");
    }
    layout.charts.push_back(c);
  }
  const fs::path triangles_file = bake_dir / record.triangles_file;
  const std::vector<std::uint32_t> triangles = read_npy_u32(triangles_file, &shape);
  if (triangles.size() != manifest.plan.triangle_count) {
    bad_light_map(triangles_file, "shape", "must hold one chart per triangle (" + std::to_string(manifest.plan.triangle_count) + ")");
  }
  layout.triangle_chart.reserve(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (triangles[t] != kNoLightMapChart && triangles[t] >= layout.charts.size()) {
      bad_light_map(triangles_file, "triangle " + std::to_string(t), "names chart " + std::to_string(triangles[t]) + " of " +
                                                               std::to_string(layout.charts.size()));
    }
    layout.triangle_chart.push_back(triangles[t] == kNoLightMapChart ? -1 : static_cast<std::int32_t>(triangles[t]));
  }
  const fs::path texels_file = bake_dir / record.texels_file;
  layout.texels = read_npy_u32(texels_file, &shape);
  const std::uint64_t atlas = static_cast<std::uint64_t>(layout.width) * static_cast<std::uint64_t>(layout.height);
  if (layout.texels.size() != manifest.plan.light_map.texels) {
    bad_light_map(texels_file, "shape", "must hold the plan's " + std::to_string(manifest.plan.light_map.texels) + " texels");
  }
  for (std::size_t k = 0; k < layout.texels.size(); ++k) {
    if (layout.texels[k] >= atlas || (k > 0 && layout.texels[k] <= layout.texels[k - 1])) {
      bad_light_map(texels_file, "texel " + std::to_string(k), "lies outside the atlas or out of ascending order");
    }
  }
  return layout;
}

LightMapForm smallest_light_map_form(const Manifest& manifest) {
  return manifest.light_map && manifest.light_map->pca ? LightMapForm::Pca : LightMapForm::Full;
}

LightMapArrays read_light_map(const fs::path& bake_dir, const Manifest& manifest, LightMapForm form) {
  LightMapArrays out{read_light_map_layout(bake_dir, manifest), {}, {}, std::nullopt};
  if (form == LightMapForm::Pca) {
    out.pca = read_light_map_pca(bake_dir, manifest, out.layout);
    return out;
  }
  if (!manifest.light_map->has_full_form()) {
    throw InputError(input_message(bake_dir / "manifest.json", -1, -1, "light_map.transfer", "is not in this bake: it keeps only the light map's PCA form (skylit-bake --light-map-pca-only)",
                                   "read its PCA form (render.light_map_form: auto or pca), or bake again without --light-map-pca-only"));
  }
  std::vector<std::size_t> shape;
  out.transfer = read_npy(bake_dir / manifest.light_map->transfer_file, &shape);
  if (!manifest.light_map->ground_file.empty()) out.ground = read_npy(bake_dir / manifest.light_map->ground_file, &shape);
  return out;
}

}  // namespace skylit::bake_format
