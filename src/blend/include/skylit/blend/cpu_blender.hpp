#pragma once
// The shadow ratios of one plane blended on the CPU (blend::blend_cpu) for the live service's
// `blend: cpu`, with the GPU blender's two savings and their bounds (gpu_blend.hpp).
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "skylit/blend/workers.hpp"
#include "skylit/blend/cpu_blend.hpp"

namespace skylit::blend {

// The two savings:
//
//   change_threshold  the blend is skipped, the last T kept, while
//                     Σ_i |Δw_{i,c}| max_x B_i(x) + Σ_k |Δw_k,c| ≤ change_threshold for every c
//                     (and the channels without light, the number of separated sources and
//                     their visibility are unchanged);
//   skip_threshold    the layers of least possible contribution c_i = max_c |w_{i,c}| max_x B_i(x)
//                     are left out while their c_i add up to at most the threshold.
//
// The GPU reads four layers per texture slice and sums all of a slice it reads; the CPU reads
// layers one by one, so with skip_threshold > 0 it may leave out a few more layers than the GPU.
// Both stay within the bound.
class CpuBlender {
 public:
  // `basis` must outlive this object. InputError for a negative or non-finite threshold.
  CpuBlender(const blend::BasisImages& basis, double skip_threshold, double change_threshold);

  // Blends with weights from blend::blend_weights for this basis, unless change_threshold says
  // the last T still holds; returns whether it ran. `sun_visibility` (V per texel, row-major) is
  // needed when weights.sun is not zero; `sun_revision` changes whenever V does.
  bool blend(const blend::BlendWeights& weights, std::span<const float> sun_visibility, std::uint64_t sun_revision,
             blend::BlendWorkers* workers);
  // The same with several separated sources (weights from blend::blend_weights_sources):
  // source_visibility holds V_k of every source, one plane's texels after another's (k · texels
  // on; empty when no source lights the plane), as blend::blend_cpu_sources takes them.
  bool blend_sources(const blend::BlendWeights& weights, std::span<const float> source_visibility,
                     std::uint64_t sun_revision, blend::BlendWorkers* workers);

  // T of the last blend as RGBA floats (T in rgb, alpha 1), row-major texels as the basis: what a
  // GL_RGBA32F texture takes as it is. A new vector for every blend that ran; null before the first.
  std::shared_ptr<const std::vector<float>> rgba() const { return rgba_; }
  int width() const { return basis_.width; }
  int height() const { return basis_.height; }
  int skipped_layers() const { return skipped_layers_; }   // of the last blend that ran
  const std::vector<float>& layer_max() const { return layer_max_; }

 private:
  bool unchanged_since_last(const blend::BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                            std::uint64_t sun_revision) const;

  const blend::BasisImages& basis_;
  double skip_threshold_;
  double change_threshold_;
  std::vector<float> layer_max_;   // max_x B_i(x) per layer
  std::vector<float> rgb_;         // blend_cpu's output, reused

  bool has_result_ = false;
  std::vector<Eigen::Vector3f> last_face_;
  std::vector<Eigen::Vector3f> last_sources_;  // the separated terms of the last blend
  std::array<bool, 3> last_no_light_{false, false, false};
  std::uint64_t last_sun_revision_ = 0;
  int skipped_layers_ = 0;
  std::shared_ptr<const std::vector<float>> rgba_;
};

}  // namespace skylit::blend
