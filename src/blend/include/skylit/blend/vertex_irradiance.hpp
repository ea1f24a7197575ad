#pragma once
// The building's irradiance per model vertex, as the compositor shades a vertex that no virtual
// plane covers (render/compositor.hpp), on the CPU: for skylit-shade's building output and the
// accuracy study's building error.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/blend/cpu_blend.hpp"
#include "skylit/geom/dome.hpp"
#include "skylit/geom/dome_basis.hpp"

namespace skylit::blend {

// The ground's light (docs/method.md, "Light from the ground"). The bake's ground layer holds
// t^g_{v,l}, the light of layer l reflected by a ground of albedo 1 with the model's shadow on it,
// and A_l(z). A separated source joins the layers of the face it lies in, weighed by its basis
// functions φ_l there (summing to 1):
//     S^g_l = S_l + Σ_k E_k max(0, ω_k·z) φ_l(ω_k) / A_l(z)
// so that the ground gives vertex v  ρ ⊙ Σ_l S^g_l t^g_{v,l}  (ρ the ground's albedo, RGB): exact
// for an unshadowed ground, and the sources' shadow on it as the dome's faces resolve it.
class GroundLayers {
 public:
  // std::invalid_argument unless horizontal_unoccluded holds one value per layer of the dome.
  GroundLayers(int frequency, geom::DomeBasis basis, std::vector<double> horizontal_unoccluded);
  // S^g; non-finite S and energies count as 0.
  std::vector<Eigen::Vector3d> coefficients(std::span<const Eigen::Vector3d> S, std::span<const SunLight> lights) const;

 private:
  geom::Dome dome_;
  geom::CornerWeights corners_;
  geom::DomeBasis basis_;
  std::vector<double> horizontal_unoccluded_;
};

// The ground at the vertices: t^g (vertex-major, as transfer), S^g and ρ. Empty transfer: none.
struct GroundLight {
  std::span<const float> transfer;
  std::vector<Eigen::Vector3d> coefficients;
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();
};

//   E(v) = Σ_i S_i t_{v,i} + Σ_k E_k max(0, n_v·ω_k) V_k(v) + ρ ⊙ Σ_l S^g_l t^g_{v,l}        (RGB)
// transfer: the bake's transfer.npy, vertex-major (S.size() values per vertex); values that are
// not finite or negative count as 0, as in the compositor; S as the sky stage gives it (a
// corner's or quadratic's coefficient may be negative). lights[k] with visibility[k] (one value
// per vertex in [0, 1], the source's disc seen from the vertex; empty: 1); the ground's transfer
// counts as the transfer vectors do. std::invalid_argument when the sizes do not fit.
std::vector<Eigen::Vector3d> vertex_irradiance(std::span<const float> transfer, std::span<const Eigen::Vector3d> S,
                                               std::span<const Eigen::Vector3f> normals, std::span<const SunLight> lights,
                                               std::span<const std::vector<float>> visibility, const GroundLight& ground = {});

}  // namespace skylit::blend
