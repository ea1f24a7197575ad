// The building's irradiance per vertex: the transfer vectors' sum and each source's term.
#include "skylit/blend/vertex_irradiance.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace skylit::blend {

GroundLayers::GroundLayers(int frequency, geom::DomeBasis basis, std::vector<double> horizontal_unoccluded)
    : dome_(frequency), corners_(dome_), basis_(basis), horizontal_unoccluded_(std::move(horizontal_unoccluded)) {
  const std::size_t layers = static_cast<std::size_t>(dome_.face_count() * geom::layers_per_face(basis_));
  if (horizontal_unoccluded_.size() != layers) {
    throw std::invalid_argument("GroundLayers: " + std::to_string(horizontal_unoccluded_.size()) +
                                " horizontal integrals for a dome of " + std::to_string(layers) + " layers");
  }
}

std::vector<Eigen::Vector3d> GroundLayers::coefficients(std::span<const Eigen::Vector3d> S, std::span<const SunLight> lights) const {
  if (S.size() != horizontal_unoccluded_.size()) {
    throw std::invalid_argument("GroundLayers: " + std::to_string(S.size()) + " sky values for " +
                                std::to_string(horizontal_unoccluded_.size()) + " layers");
  }
  const auto finite = [](const Eigen::Vector3d& x) {
    return Eigen::Vector3d(std::isfinite(x[0]) ? x[0] : 0.0, std::isfinite(x[1]) ? x[1] : 0.0, std::isfinite(x[2]) ? x[2] : 0.0);
  };
  std::vector<Eigen::Vector3d> out(S.size());
  for (std::size_t l = 0; l < S.size(); ++l) out[l] = finite(S[l]);
  const int per_face = geom::layers_per_face(basis_);
  for (const SunLight& light : lights) {
    const double length = light.direction.norm();
    if (!(length > 0.0) || !std::isfinite(length)) continue;
    const Vec3 w = light.direction / length;
    const int face = dome_.face_of(w);
    if (face < 0 || w.z() <= 0.0) continue;  // below the horizon: it lights no ground
    const geom::LayerValues phi = basis_ == geom::DomeBasis::Faces ? geom::LayerValues{1.0}
                                                                    : geom::layer_values(basis_, corners_(face, w));
    const Eigen::Vector3d energy = finite(light.energy) * w.z();
    for (int k = 0; k < per_face; ++k) {
      const std::size_t l = static_cast<std::size_t>(face * per_face + k);
      const double a = horizontal_unoccluded_[l];
      if (a > 0.0) out[l] += (phi[static_cast<std::size_t>(k)] / a) * energy;
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> vertex_irradiance(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const Eigen::Vector3f> normals, std::span<const SunLight> lights,
                                               std::span<const std::vector<float>> visibility, const GroundLight& ground) {
  if (!ground.transfer.empty() && (ground.transfer.size() != transfer.size() || ground.coefficients.size() != S.size())) {
    throw std::invalid_argument("vertex_irradiance: the ground's transfer holds " + std::to_string(ground.transfer.size()) +
                                " values and " + std::to_string(ground.coefficients.size()) + " coefficients, not " +
                                std::to_string(transfer.size()) + " and " + std::to_string(S.size()));
  }
  const std::size_t vertices = normals.size(), layers = S.size();
  if (transfer.size() != vertices * layers) {
    throw std::invalid_argument("vertex_irradiance: the transfer array holds " + std::to_string(transfer.size()) +
                                " values, not vertices × layers = " + std::to_string(vertices) + " × " + std::to_string(layers));
  }
  if (visibility.size() != lights.size()) throw std::invalid_argument("vertex_irradiance: one visibility per light");
  for (const std::vector<float>& v : visibility) {
    if (!v.empty() && v.size() != vertices) throw std::invalid_argument("vertex_irradiance: one visibility value per vertex");
  }
  std::vector<Eigen::Vector3d> out(vertices, Eigen::Vector3d::Zero());
  for (std::size_t v = 0; v < vertices; ++v) {
    const float* t = transfer.data() + v * layers;
    for (std::size_t i = 0; i < layers; ++i) {
      if (std::isfinite(t[i]) && t[i] > 0.0f) out[v] += static_cast<double>(t[i]) * S[i];
    }
    const Eigen::Vector3d n = normals[v].cast<double>();
    for (std::size_t k = 0; k < lights.size(); ++k) {
      const double facing = std::max(0.0, n.dot(lights[k].direction));
      if (facing == 0.0) continue;
      const double seen = visibility[k].empty() ? 1.0 : std::clamp(static_cast<double>(visibility[k][v]), 0.0, 1.0);
      out[v] += facing * seen * lights[k].energy;
    }
    if (!ground.transfer.empty()) {
      Eigen::Vector3d reflected = Eigen::Vector3d::Zero();
      const float* tg = ground.transfer.data() + v * layers;
      for (std::size_t l = 0; l < layers; ++l) {
        if (std::isfinite(tg[l]) && tg[l] > 0.0f) reflected += static_cast<double>(tg[l]) * ground.coefficients[l];
      }
      out[v] += ground.albedo.cwiseProduct(reflected);
    }
  }
  return out;
}

}  // namespace skylit::blend
