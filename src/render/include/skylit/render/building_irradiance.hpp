#pragma once
// The building's sky and ground irradiance for a sky, summed on the CPU from the bake's transfer
// vectors, ground layer and light map: what a Compositor lights the building with. Summed once
// per sky, on any thread (the live service's sky thread, so that a frame with a new sky does not
// wait for it), and shared by every compositor of a stereo HMD.
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/light_map.hpp"
#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/scene/mesh.hpp"

namespace skylit::render {

class LightMapSums;

// How the light map's values are held for the sums (render.light_map_precision): in float, or in
// IEEE half floats, half the memory and half the bytes a sum reads, each value rounded to within
// 2^-11 of itself (bench/RESULTS.md, "The light map's sums in SIMD and in half floats": the
// building moves by at most 0.00006 of E_h).
enum class LightMapPrecision { Float, Half };
// "float", "half".
const char* light_map_precision_name(LightMapPrecision precision);

// One sky's sums (BuildingIrradiance::sum).
struct SkyIrradiance {
  std::vector<Eigen::Vector3d> sky;     // S as summed (BuildingIrradiance::cleaned_sky)
  std::vector<Eigen::Vector3d> ground;  // S^g of the sky and its sources (empty without the ground's light)
  // Each at least 0 (a negative coefficient may take a sum below):
  std::vector<float> vertices;          // rgb per model vertex: Σ_i S_i t_{v,i} + ρ ⊙ Σ_l S^g_l t^g_{v,l}
  std::vector<float> ground_vertices;   // rgb per model vertex: ρ ⊙ Σ_l S^g_l t^g_{v,l} alone (empty: none)
  std::vector<float> atlas;             // RGBA per texel of the light map's atlas, row-major (empty: no map)
  const void* summed_by = nullptr;      // the BuildingIrradiance that summed it
};

class BuildingIrradiance {
 public:
  // transfer: the bake's transfer.npy (vertices × layers, vertex-major). ground_albedo (RGB in
  // [0, 1]; zero: no light from the ground) with ground_transfer, the bake's ground layer (as
  // transfer). light_map: the bake's light map in either form (no texels: none; its ground's
  // with the ground on), its values held at `precision`. InputError naming the field and the fix
  // when they do not fit the model and the bake, or a value does not fit a half float.
  BuildingIrradiance(const scene::Mesh& mesh, const bake_format::Manifest& manifest, std::span<const float> transfer,
                     const Eigen::Vector3d& ground_albedo, std::span<const float> ground_transfer,
                     bake_format::LightMapArrays light_map, LightMapPrecision precision = LightMapPrecision::Float);
  ~BuildingIrradiance();
  BuildingIrradiance(const BuildingIrradiance&) = delete;
  BuildingIrradiance& operator=(const BuildingIrradiance&) = delete;

  // The sky's S as summed: values that are not finite count as 0, and so do negative ones in a
  // faces basis (radiances); a corner's or quadratic's coefficient may be negative (a fit's
  // undershoot beside a bright spot) and is kept, as the blend keeps it. `replaced` counts the
  // values taken as 0. With S^g for these sources (the sun and the lamps), the key a sum is made
  // for: a frame whose pair differs needs a new one.
  std::vector<Eigen::Vector3d> cleaned_sky(std::span<const Eigen::Vector3d> sky, int* replaced = nullptr) const;
  std::vector<Eigen::Vector3d> ground_coefficients(std::span<const Eigen::Vector3d> cleaned, const std::optional<blend::SunLight>& sun,
                                                   std::span<const blend::SunLight> lamps) const;
  // The sums for a sky with these sources (S with layer_count() values, else InputError). Const
  // and thread-safe: any number may run at once, each on every core.
  SkyIrradiance sum(std::span<const Eigen::Vector3d> sky, const std::optional<blend::SunLight>& sun,
                    std::span<const blend::SunLight> lamps) const;

  std::size_t vertex_count() const { return vertex_count_; }
  std::size_t layer_count() const { return layer_count_; }
  bool ground_light() const { return ground_layers_.has_value(); }
  // The light map's layout (null: none), and its atlas's size.
  const bake_format::LightMapLayout* light_map_layout() const { return light_map_ ? &layout_ : nullptr; }
  int atlas_width() const { return layout_.width; }
  int atlas_height() const { return layout_.height; }
  // The bytes the light map's values take (0: none), at its precision.
  std::size_t light_map_bytes() const;

 private:
  std::size_t vertex_count_ = 0, layer_count_ = 0;
  bool negative_coefficients_ = false;  // the dome's basis has coefficients that may be negative
  std::vector<float> transfer_by_layer_, ground_by_layer_;  // t_{v,i} at [i · vertex_count + v], finite, ≥ 0
  Eigen::Vector3d ground_albedo_ = Eigen::Vector3d::Zero();
  std::optional<blend::GroundLayers> ground_layers_;
  bake_format::LightMapLayout layout_;
  std::unique_ptr<LightMapSums> light_map_;
};

}  // namespace skylit::render
