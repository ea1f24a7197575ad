// The live GPU path for the accuracy study (see gpu_path.hpp).
#include "skylit/study/gpu_path.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>

#include "skylit/baker/vertex_fit.hpp"
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
                       render::SunShadowOptions map, const blend::GpuBlendOptions& blend, const blend::GroundLight& ground,
                       const TrianglePoints* points) {
  if (radii.size() != sources.size()) throw std::invalid_argument("gpu_path: one angular radius per source");
  std::vector<geom::Plane> planes;
  for (const bake_format::PlaneRecord& record : manifest.planes) planes.push_back(record.plane);
  GpuPathResult out;
  std::optional<render::SunShadowMap> maps;
  if (!sources.empty()) {
    map.max_sources = std::max(map.max_sources, static_cast<int>(sources.size()));
    // The points ride along as vertices no triangle uses: the maps give V there as at a vertex.
    maps.emplace(points != nullptr ? baker::with_points(mesh, points->positions, points->normals) : mesh, planes, map);
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

  for (std::size_t k = 0; k < sources.size(); ++k) {
    std::vector<float> all = maps->read_vertex_visibility(static_cast<int>(k));
    const auto model = static_cast<std::ptrdiff_t>(mesh.vertex_count());
    if (points != nullptr) out.point_visibility.emplace_back(all.begin() + model, all.end());
    all.resize(mesh.vertex_count());
    out.vertex_visibility.push_back(std::move(all));
  }
  out.building = blend::vertex_irradiance(transfer, S, mesh.normals, sources, out.vertex_visibility, ground);
  return out;
}

InsideTerms gpu_terms_inside(const TrianglePoints& points, std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                             std::span<const blend::SunLight> sources, bool sun_first, const scene::Mesh& mesh,
                             const GpuPathResult& g, const blend::GroundLight& ground) {
  if (g.point_visibility.size() != sources.size() || g.vertex_visibility.size() != sources.size()) {
    throw std::invalid_argument("gpu_terms_inside: gpu_path gives no V at the points for every source");
  }
  const std::size_t first = sun_first && !sources.empty() ? 1 : 0;
  InsideTerms terms;
  terms.sky = interpolated_at(points, blend::vertex_irradiance(transfer, S, mesh.normals, sources.subspan(first),
                                                               std::span(g.vertex_visibility).subspan(first)));
  terms.sun.assign(points.positions.size(), Eigen::Vector3d::Zero());
  if (first == 1) {
    const Eigen::Vector3d w = sources.front().direction.normalized();
    for (std::size_t k = 0; k < points.positions.size(); ++k) {
      const double facing = std::max(0.0, points.normals[k].cast<double>().dot(w));
      terms.sun[k] = facing * static_cast<double>(g.point_visibility.front().at(k)) * sources.front().energy;
    }
  }
  terms.ground.assign(points.positions.size(), Eigen::Vector3d::Zero());
  if (!ground.transfer.empty()) {
    const std::vector<Eigen::Vector3d> no_sky(S.size(), Eigen::Vector3d::Zero());
    terms.ground = interpolated_at(points, blend::vertex_irradiance(transfer, no_sky, mesh.normals, {}, {}, ground));
  }
  return terms;
}

}  // namespace skylit::study
