// The building's irradiance per sky on the CPU (building_irradiance.hpp).
#include "skylit/render/building_irradiance.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "skylit/base/error.hpp"
#include "building_light.hpp"

namespace skylit::render {
namespace {

std::vector<Eigen::Vector3f> as_float(std::span<const Eigen::Vector3d> values, const Eigen::Vector3d& scale) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(values.size());
  for (const Eigen::Vector3d& v : values) out.push_back(scale.cwiseProduct(v).cast<float>());
  return out;
}

// A negative coefficient may take a sum below 0: no light is the least there is.
void at_least_zero(std::vector<float>& values) {
  for (float& x : values) x = std::max(x, 0.0f);
}

}  // namespace

BuildingIrradiance::BuildingIrradiance(const scene::Mesh& mesh, const bake_format::Manifest& manifest, std::span<const float> transfer,
                                       const Eigen::Vector3d& ground_albedo, std::span<const float> ground_transfer,
                                       bake_format::LightMapArrays light_map, LightMapPrecision precision)
    : vertex_count_(mesh.vertex_count()), layer_count_(manifest.layer_count()),
      negative_coefficients_(manifest.plan.basis != geom::DomeBasis::Faces) {
  const std::size_t expected = vertex_count_ * layer_count_;
  if (expected == 0 || transfer.size() != expected) {
    throw InputError(input_message("manifest.json", -1, -1, "transfer",
                                   "transfer.npy holds " + std::to_string(transfer.size()) + " values, not vertices × layers = " +
                                       std::to_string(vertex_count_) + " × " + std::to_string(layer_count_),
                                   "use the model and the bake that belong together (re-bake after changing the model)"));
  }
  transfer_by_layer_ = layer_major(transfer, vertex_count_, layer_count_);
  if (!ground_albedo.isZero(0)) {
    if (!ground_albedo.allFinite() || ground_albedo.minCoeff() < 0.0 || ground_albedo.maxCoeff() > 1.0) {
      throw InputError(input_message({}, -1, -1, "ground albedo", "each channel must lie in [0, 1]",
                                     "set render.ground_albedo to the ground's reflectance, e.g. 0.2"));
    }
    if (!manifest.ground || ground_transfer.size() != expected) {
      throw InputError(input_message({}, -1, -1, "ground",
                                     manifest.ground ? "the ground's transfer holds " + std::to_string(ground_transfer.size()) +
                                                           " values, not vertices × layers = " + std::to_string(expected)
                                                     : "the bake has no ground layer (its plan's ground_samples is 0)",
                                     "re-bake with skylit-bake --ground-samples 256, or turn the ground's light off "
                                     "(render.ground_light: false)"));
    }
    try {
      ground_layers_.emplace(manifest.plan.frequency, manifest.plan.basis, manifest.ground->horizontal_unoccluded);
    } catch (const std::invalid_argument& e) {
      throw InputError(input_message({}, -1, -1, "ground.horizontal_unoccluded", e.what(), "re-bake"));
    }
    ground_albedo_ = ground_albedo;
    ground_by_layer_ = layer_major(ground_transfer, vertex_count_, layer_count_);
  }
  if (!light_map.layout.texels.empty()) {
    LightMapSums::check(light_map, ground_light(), mesh, layer_count_);
    layout_ = light_map.layout;
    light_map_ = std::make_unique<LightMapSums>(std::move(light_map), ground_light(), layer_count_, precision);
  }
}

BuildingIrradiance::~BuildingIrradiance() = default;

std::size_t BuildingIrradiance::light_map_bytes() const { return light_map_ ? light_map_->value_bytes() : 0; }

const char* light_map_precision_name(LightMapPrecision precision) {
  return precision == LightMapPrecision::Half ? "half" : "float";
}

std::vector<Eigen::Vector3d> BuildingIrradiance::cleaned_sky(std::span<const Eigen::Vector3d> sky, int* replaced) const {
  std::vector<Eigen::Vector3d> out;
  out.reserve(sky.size());
  for (const Eigen::Vector3d& S : sky) {
    out.push_back(negative_coefficients_ ? finite_or_zero(S, replaced) : finite_nonnegative(S, replaced));
  }
  return out;
}

std::vector<Eigen::Vector3d> BuildingIrradiance::ground_coefficients(std::span<const Eigen::Vector3d> cleaned,
                                                                     const std::optional<blend::SunLight>& sun,
                                                                     std::span<const blend::SunLight> lamps) const {
  if (!ground_layers_) return {};
  std::vector<blend::SunLight> lights(lamps.begin(), lamps.end());
  if (sun) lights.push_back(*sun);
  return ground_layers_->coefficients(cleaned, lights);
}

SkyIrradiance BuildingIrradiance::sum(std::span<const Eigen::Vector3d> sky, const std::optional<blend::SunLight>& sun,
                                      std::span<const blend::SunLight> lamps) const {
  if (sky.size() != layer_count_) {
    throw InputError(input_message("manifest.json", -1, -1, "dome.faces",
                                   "the sky has " + std::to_string(sky.size()) + " values, the bake " + std::to_string(layer_count_) +
                                       " basis layers",
                                   "estimate the sky on the bake's dome (the same frequency and basis)"));
  }
  SkyIrradiance out;
  out.summed_by = this;
  out.sky = cleaned_sky(sky);
  out.ground = ground_coefficients(out.sky, sun, lamps);
  // E_v = Σ_i S_i t_{v,i} in float, layer after layer, every vertex of a layer at once.
  out.vertices = sum_layers(transfer_by_layer_, vertex_count_, as_float(out.sky, Eigen::Vector3d::Ones()));
  if (ground_layers_) {
    out.ground_vertices = sum_layers(ground_by_layer_, vertex_count_, as_float(out.ground, ground_albedo_));
    for (std::size_t k = 0; k < out.vertices.size(); ++k) out.vertices[k] += out.ground_vertices[k];
    at_least_zero(out.ground_vertices);
  }
  at_least_zero(out.vertices);
  if (light_map_) out.atlas = light_map_->sum(out.sky, out.ground, ground_albedo_);
  at_least_zero(out.atlas);
  return out;
}

}  // namespace skylit::render
