// EquirectLights, the building's reference and estimate, and their errors.
#include "skylit/study/building_light.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>

#include "skylit/baker/ground_transfer.hpp"
#include "skylit/baker/vertex_fit.hpp"
#include "skylit/baker/visibility.hpp"
#include "skylit/blend/vertex_irradiance.hpp"
#include "skylit/sky/radiometry.hpp"

namespace skylit::study {

Eigen::Vector3d horizontal_irradiance(const EquirectLights& lights) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < lights.directions.size(); ++k) sum += std::max(0.0, lights.directions[k].z()) * lights.weights[k];
  return sum;
}

std::vector<Eigen::Vector3d> building_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh) {
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  baker::weighted_vertex_irradiance(mesh, site.planes, lights.directions, lights.weights, out);
  return out;
}

std::vector<Eigen::Vector3d> building_estimate(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const SourceLight> sources, const scene::Site& site,
                                               const scene::Mesh& mesh, const blend::GroundLight& ground) {
  std::vector<blend::SunLight> lights;
  std::vector<std::vector<float>> visibility;
  for (const SourceLight& source : sources) {
    lights.push_back({source.direction, source.energy});
    visibility.emplace_back(mesh.vertex_count(), 1.0f);
    if (!source.disc_directions.empty()) {
      baker::area_light_vertex_visibility(mesh, site.planes, source.disc_directions, source.disc_weights, visibility.back());
    }
  }
  return blend::vertex_irradiance(transfer, S, mesh.normals, lights, visibility, ground);
}

namespace {

// The same triangles, and the points as vertices none of them uses: traced as vertices are.
scene::Mesh mesh_with_points(const scene::Mesh& mesh, const TrianglePoints& points) {
  return baker::with_points(mesh, points.positions, points.normals);
}

}  // namespace

TrianglePoints triangle_points(const scene::Mesh& mesh) {
  TrianglePoints points;
  const std::array<Eigen::Vector3d, 4> barycentric{Eigen::Vector3d(1.0, 1.0, 1.0) / 3.0, Eigen::Vector3d(4.0, 1.0, 1.0) / 6.0,
                                                   Eigen::Vector3d(1.0, 4.0, 1.0) / 6.0, Eigen::Vector3d(1.0, 1.0, 4.0) / 6.0};
  for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const std::array<std::uint32_t, 3> c{mesh.indices[t], mesh.indices[t + 1], mesh.indices[t + 2]};
    const double area = 0.5 * static_cast<double>((mesh.positions[c[1]] - mesh.positions[c[0]]).cross(mesh.positions[c[2]] - mesh.positions[c[0]]).norm());
    for (const Eigen::Vector3d& b : barycentric) {
      Eigen::Vector3f p = Eigen::Vector3f::Zero(), n = Eigen::Vector3f::Zero();
      for (int k = 0; k < 3; ++k) {
        p += static_cast<float>(b[k]) * mesh.positions[c[static_cast<std::size_t>(k)]];
        n += static_cast<float>(b[k]) * mesh.normals[c[static_cast<std::size_t>(k)]];
      }
      if (!(n.norm() > 0.0f)) continue;  // opposite normals cancel: no surface to light
      points.positions.push_back(p);
      points.normals.push_back(n.normalized());
      points.corners.push_back(c);
      points.weights.push_back(b);
      points.areas.push_back(area / 4.0);
    }
  }
  return points;
}

std::vector<Eigen::Vector3d> interpolated_at(const TrianglePoints& points, std::span<const Eigen::Vector3d> vertex_E) {
  std::vector<Eigen::Vector3d> out(points.positions.size(), Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < out.size(); ++k) {
    for (int c = 0; c < 3; ++c) out[k] += points.weights[k][c] * vertex_E[points.corners[k][static_cast<std::size_t>(c)]];
  }
  return out;
}

std::vector<Eigen::Vector3d> source_term_at(const TrianglePoints& points, const SourceLight& source, const scene::Site& site,
                                            const scene::Mesh& mesh) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  std::vector<float> visibility(with_points.vertex_count(), 1.0f);
  if (!source.disc_directions.empty()) {
    baker::area_light_vertex_visibility(with_points, site.planes, source.disc_directions, source.disc_weights, visibility);
  }
  const Vec3 w = source.direction.normalized();
  std::vector<Eigen::Vector3d> out(points.positions.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    const double facing = std::max(0.0, points.normals[k].cast<double>().dot(w));
    out[k] = facing * static_cast<double>(visibility[mesh.vertex_count() + k]) * source.energy;
  }
  return out;
}

std::vector<Eigen::Vector3d> building_estimate_inside(const TrianglePoints& points, std::span<const float> transfer,
                                                      std::span<const Eigen::Vector3d> S, std::span<const SourceLight> sources,
                                                      bool sun_first, const scene::Site& site, const scene::Mesh& mesh,
                                                      const blend::GroundLight& ground) {
  if (!sun_first || sources.empty()) return interpolated_at(points, building_estimate(transfer, S, sources, site, mesh, ground));
  std::vector<Eigen::Vector3d> out = interpolated_at(points, building_estimate(transfer, S, sources.subspan(1), site, mesh, ground));
  const std::vector<Eigen::Vector3d> sun_term = source_term_at(points, sources.front(), site, mesh);
  for (std::size_t k = 0; k < out.size(); ++k) out[k] += sun_term[k];
  return out;
}

std::vector<Eigen::Vector3d> building_reference_at(const EquirectLights& lights, const scene::Site& site,
                                                   const scene::Mesh& mesh, const TrianglePoints& points) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  std::vector<Eigen::Vector3d> all(with_points.vertex_count());
  baker::weighted_vertex_irradiance(with_points, site.planes, lights.directions, lights.weights, all);
  return {all.begin() + static_cast<std::ptrdiff_t>(mesh.vertex_count()), all.end()};
}

std::vector<Eigen::Vector3d> ground_reference(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                              const GroundReferenceOptions& options) {
  const Eigen::Vector3d horizontal = horizontal_irradiance(lights);
  const Eigen::Vector3d scale = options.albedo / std::numbers::pi;
  const geom::Plane* plane = options.shadow_plane;
  if (plane != nullptr && options.shadow_ratio.size() != static_cast<std::size_t>(plane->width) * static_cast<std::size_t>(plane->height)) {
    throw std::invalid_argument("ground_reference: the shadow ratio has " + std::to_string(options.shadow_ratio.size()) +
                                " texels, not the plane's " + std::to_string(plane->width) + "×" + std::to_string(plane->height));
  }
  const auto radiance = [&](double x, double y) -> Eigen::Vector3d {
    Eigen::Vector3d ratio = Eigen::Vector3d::Ones();
    if (plane != nullptr) {
      const Vec3 d = Vec3(x, y, plane->origin.z()) - plane->origin;
      const double s = d.dot(plane->u) / plane->u.squaredNorm(), t = d.dot(plane->v) / plane->v.squaredNorm();
      if (s >= 0.0 && s < 1.0 && t >= 0.0 && t < 1.0) {
        const auto col = static_cast<std::size_t>(s * plane->width), row = static_cast<std::size_t>(t * plane->height);
        ratio = options.shadow_ratio[row * static_cast<std::size_t>(plane->width) + col];
      }
    }
    return scale.cwiseProduct(ratio).cwiseProduct(horizontal);
  };
  const std::vector<Vec3> directions = baker::ground_directions(options.directions);
  const std::vector<double> weights(directions.size(), 2.0 * std::numbers::pi / options.directions);
  std::vector<Eigen::Vector3d> out(mesh.vertex_count());
  baker::ground_vertex_irradiance(mesh, site.planes, directions, weights, radiance, out);
  return out;
}

GroundReferenceOptions site_ground(const scene::Site& site, const DenseReference& dense, const Eigen::Vector3d& albedo) {
  GroundReferenceOptions options;
  options.albedo = albedo;
  for (std::size_t j = 0; j < site.planes.size() && j < dense.planes.size(); ++j) {
    const geom::Plane& p = site.planes[j];
    if (p.normal().z() > 0.999 && std::abs(p.origin.z()) < 0.05) {
      options.shadow_plane = &p;
      options.shadow_ratio = dense.planes[j];
      break;
    }
  }
  return options;
}

std::vector<Eigen::Vector3d> ground_reference_at(const EquirectLights& lights, const scene::Site& site, const scene::Mesh& mesh,
                                                 const TrianglePoints& points, const GroundReferenceOptions& options) {
  const scene::Mesh with_points = mesh_with_points(mesh, points);
  const std::vector<Eigen::Vector3d> all = ground_reference(lights, site, with_points, options);
  return {all.begin() + static_cast<std::ptrdiff_t>(mesh.vertex_count()), all.end()};
}

Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal) {
  if (estimate.size() != reference.size()) throw std::invalid_argument("building_errors: estimate and reference differ in length");
  std::vector<double> diffs;
  diffs.reserve(3 * estimate.size());
  for (std::size_t v = 0; v < estimate.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (horizontal[c] > 0) diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
    }
  }
  return errors_of(std::move(diffs));
}

Errors building_errors(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                       const Eigen::Vector3d& horizontal, std::span<const double> areas) {
  if (estimate.size() != reference.size() || estimate.size() != areas.size()) {
    throw std::invalid_argument("building_errors: estimate, reference and areas differ in length");
  }
  std::vector<double> diffs, weights;
  for (std::size_t v = 0; v < estimate.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      if (!(horizontal[c] > 0)) continue;
      diffs.push_back(std::abs(estimate[v][c] - reference[v][c]) / horizontal[c]);
      weights.push_back(areas[v]);
    }
  }
  return errors_of(diffs, weights);
}

std::size_t worst_vertex(std::span<const Eigen::Vector3d> estimate, std::span<const Eigen::Vector3d> reference,
                         const Eigen::Vector3d& horizontal) {
  std::size_t worst = 0;
  double largest = -1;
  for (std::size_t v = 0; v < std::min(estimate.size(), reference.size()); ++v) {
    for (int c = 0; c < 3; ++c) {
      const double e = horizontal[c] > 0 ? std::abs(estimate[v][c] - reference[v][c]) / horizontal[c] : 0.0;
      if (e > largest) {
        largest = e;
        worst = v;
      }
    }
  }
  return worst;
}

}  // namespace skylit::study
