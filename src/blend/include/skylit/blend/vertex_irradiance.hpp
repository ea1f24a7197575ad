#pragma once
// The building's irradiance per model vertex, as the compositor shades a vertex that no virtual
// plane covers (render/compositor.hpp), on the CPU: for skylit-shade's building output and the
// accuracy study's building error.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/blend/cpu_blend.hpp"

namespace skylit::blend {

//   E(v) = Σ_i S_i t_{v,i} + Σ_k E_k max(0, n_v·ω_k) V_k(v)        (RGB)
// transfer: the bake's transfer.npy, vertex-major (S.size() values per vertex); values that are
// not finite or negative count as 0, as in the compositor; S as the sky stage gives it (a
// corner's or quadratic's coefficient may be negative). lights[k] with visibility[k] (one value
// per vertex in [0, 1], the source's disc seen from the vertex; empty: 1). std::invalid_argument
// when the sizes do not fit.
std::vector<Eigen::Vector3d> vertex_irradiance(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const Eigen::Vector3f> normals, std::span<const SunLight> lights,
                                               std::span<const std::vector<float>> visibility);

}  // namespace skylit::blend
