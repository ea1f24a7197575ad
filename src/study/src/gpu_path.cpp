// The live GPU path for the accuracy study (see gpu_path.hpp).
#include "skylit/study/gpu_path.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>

#include "skylit/blend/basis.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/gpu/gl.hpp"

namespace skylit::study {
namespace {

double milliseconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

GpuPathResult gpu_path(const std::filesystem::path& bake_dir, const bake_format::Manifest& manifest,
                       const scene::Mesh& mesh, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                       std::span<const blend::SunLight> sources, std::span<const double> radii,
                       render::SunShadowOptions map, const blend::GpuBlendOptions& blend, const blend::GroundLight& ground) {
  if (radii.size() != sources.size()) throw std::invalid_argument("gpu_path: one angular radius per source");
  std::vector<geom::Plane> planes;
  for (const bake_format::PlaneRecord& record : manifest.planes) planes.push_back(record.plane);
  GpuPathResult out;
  std::optional<render::SunShadowMap> maps;
  if (!sources.empty()) {
    map.max_sources = std::max(map.max_sources, static_cast<int>(sources.size()));
    maps.emplace(mesh, planes, map);
    std::vector<render::ShadowSource> drawn;
    for (std::size_t k = 0; k < sources.size(); ++k) drawn.push_back({sources[k].direction, radii[k]});
    glFinish();
    const auto start = std::chrono::steady_clock::now();
    maps->update(drawn);
    glFinish();
    out.shadow_ms = milliseconds_since(start);
  }
  std::vector<std::unique_ptr<blend::GpuBlender>> blenders;
  std::vector<blend::BlendWeights> weights;
  std::vector<blend::BasisImages> bases;
  for (std::size_t j = 0; j < manifest.planes.size(); ++j) {
    bases.push_back(blend::load_basis(bake_dir, manifest, static_cast<int>(j)));
    blenders.push_back(std::make_unique<blend::GpuBlender>(bases.back(), blend));
    weights.push_back(blend::blend_weights_sources(bases.back(), S, sources));
  }
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t j = 0; j < blenders.size(); ++j) {
    blenders[j]->blend(weights[j], maps ? &maps->visibility(static_cast<int>(j)) : nullptr);
  }
  glFinish();
  out.blend_ms = milliseconds_since(start);
  for (const auto& blender : blenders) out.ratios.push_back(blender->read_back());
  for (std::size_t j = 0; j < planes.size(); ++j) {
    out.visibility.emplace_back();
    for (std::size_t k = 0; k < sources.size(); ++k) {
      out.visibility.back().push_back(maps->read_visibility(static_cast<int>(j), static_cast<int>(k)));
    }
  }

  for (std::size_t k = 0; k < sources.size(); ++k) out.vertex_visibility.push_back(maps->read_vertex_visibility(static_cast<int>(k)));
  out.building = blend::vertex_irradiance(transfer, S, mesh.normals, sources, out.vertex_visibility, ground);
  return out;
}

}  // namespace skylit::study
