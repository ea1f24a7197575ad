#pragma once
// The live GPU path in the accuracy study: every separated source's shadow map (SunShadowMap),
// the GPU blend of each plane (GpuBlender), and the building's vertices lit through the maps, so
// that the study measures what a site runs, beside the CPU path's ray-cast visibility.
#include <filesystem>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/bake_format/manifest.hpp"
#include "skylit/blend/cpu_blend.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/render/sun_shadow_map.hpp"
#include "skylit/scene/mesh.hpp"
#include "skylit/study/building_light.hpp"

namespace skylit::study {

struct GpuPathResult {
  std::vector<std::vector<float>> ratios;   // per plane: T, width × height × 3 floats (RGB)
  std::vector<std::vector<std::vector<float>>> visibility;  // [plane][source]: V per texel, from the maps
  std::vector<std::vector<float>> vertex_visibility;  // [source]: V per mesh vertex, from the maps
  std::vector<Eigen::Vector3d> building;    // per vertex: Σ S t + Σ_k E_k max(0, n·ω_k) V_k (V from the maps)
  std::vector<std::vector<float>> point_visibility;  // [source]: V at gpu_path's `points`, from the maps
  double shadow_ms = 0;  // drawing every source's map (depth, pyramid, plane and vertex V), GPU finished
  double blend_ms = 0;   // the GPU blend of every plane, GPU finished
};

// T of every plane of the bake and the building's vertex irradiance, as the live GPU path gives
// them for sky S and the separated sources (the sun first when there is one; `radii` their
// discs' angular radii). A GL ES 3.1 context must be current. `map` and `blend` as the live
// service's (sky.max_sources sets map.max_sources; it is raised to the sources' count here).
// `ground`: the ground's light on the building, as the live service adds it (render.ground_light).
// With `points`, the maps also give each source's V there (point_visibility), as the compositor
// samples the sun's map per fragment.
GpuPathResult gpu_path(const std::filesystem::path& bake_dir, const bake_format::Manifest& manifest,
                       const scene::Mesh& mesh, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                       std::span<const blend::SunLight> sources, std::span<const double> radii,
                       render::SunShadowOptions map = {}, const blend::GpuBlendOptions& blend = {},
                       const blend::GroundLight& ground = {}, const TrianglePoints* points = nullptr);

// The building inside the triangles as the compositor shows it on the GPU path, term by term
// (building_terms_inside's split): the sky, the lamps and the ground interpolated from the
// vertices, each lamp's V from its map at the vertices; with sun_first, sources[0] per point, V
// from its map at the point. `g` from gpu_path with these points and sources.
// std::invalid_argument when g holds no V at the points for every source.
InsideTerms gpu_terms_inside(const TrianglePoints& points, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                             std::span<const blend::SunLight> sources, bool sun_first, const scene::Mesh& mesh,
                             const GpuPathResult& g, const blend::GroundLight& ground = {});

}  // namespace skylit::study
