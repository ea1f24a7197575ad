// EquirectLights, the building's reference and estimate, and their errors.
#include "skylit/study/building_light.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

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
                                               const scene::Mesh& mesh) {
  std::vector<blend::SunLight> lights;
  std::vector<std::vector<float>> visibility;
  for (const SourceLight& source : sources) {
    lights.push_back({source.direction, source.energy});
    visibility.emplace_back(mesh.vertex_count(), 1.0f);
    if (!source.disc_directions.empty()) {
      baker::area_light_vertex_visibility(mesh, site.planes, source.disc_directions, source.disc_weights, visibility.back());
    }
  }
  return blend::vertex_irradiance(transfer, S, mesh.normals, lights, visibility);
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
