// The building's irradiance per vertex: the transfer vectors' sum and each source's term.
#include "skylit/blend/vertex_irradiance.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace skylit::blend {

std::vector<Eigen::Vector3d> vertex_irradiance(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const Eigen::Vector3f> normals, std::span<const SunLight> lights,
                                               std::span<const std::vector<float>> visibility) {
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
  }
  return out;
}

}  // namespace skylit::blend
