#include "skylit/blend/cpu_blender.hpp"
#include "skylit/blend/half.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "skylit/base/error.hpp"

namespace skylit::blend {

CpuBlender::CpuBlender(const blend::BasisImages& basis, double skip_threshold, double change_threshold)
    : basis_(basis), skip_threshold_(skip_threshold), change_threshold_(change_threshold) {
  for (const auto& [value, field] : {std::pair{skip_threshold, "blend.skip_threshold"},
                                     std::pair{change_threshold, "blend.change_threshold"}}) {
    if (!std::isfinite(value) || value < 0.0) {
      throw InputError(input_message({}, -1, -1, field, std::to_string(value) + " is not finite and >= 0",
                                     "use 0 (exact) or a small fraction of full light such as 0.002"));
    }
  }
  const std::size_t texels = basis.texel_count();
  layer_max_.assign(static_cast<std::size_t>(basis.layers), 0.0f);
  std::vector<float> values;
  for (std::size_t i = 0; i < layer_max_.size(); ++i) {
    // A whole layer, or (cropped) the layer's rectangle, its fill holding everywhere else.
    std::size_t offset = i * texels;
    std::size_t count = texels;
    float top = 0.0f;
    if (basis.cropped()) {
      const blend::LayerCrop& crop = basis.crops.at(i);
      offset = crop.offset;
      count = static_cast<std::size_t>(crop.cols) * static_cast<std::size_t>(crop.rows);
      if (count < texels) top = std::abs(crop.fill) > top ? std::abs(crop.fill) : top;
    }
    values.resize(count);
    blend::halves_to_floats(std::span<const std::uint16_t>(basis.half.data() + offset, count), values);
    // max |B|: a PCA basis has eigen-images of either sign.
    for (const float b : values) top = std::abs(b) > top ? std::abs(b) : top;  // NaN compares false: ignored
    layer_max_[i] = top;
  }
  rgb_.resize(3 * texels);
}

namespace {

bool any_lit(const std::vector<Eigen::Vector3f>& terms) {
  return std::any_of(terms.begin(), terms.end(), [](const Eigen::Vector3f& w) { return !w.isZero(0); });
}

}  // namespace

bool CpuBlender::unchanged_since_last(const blend::BlendWeights& weights, const std::vector<Eigen::Vector3f>& terms,
                                      std::uint64_t sun_revision) const {
  if (!has_result_ || weights.no_light != last_no_light_ || weights.face.size() != last_face_.size() ||
      terms.size() != last_sources_.size()) {
    return false;
  }
  if (any_lit(terms) && any_lit(last_sources_) && sun_revision != last_sun_revision_) return false;
  // The largest change of T any texel can see, per channel (B ≤ layer_max, V ≤ 1).
  // A tiled basis (clustered PCA) has a set of weights per tile; summed over every tile, the
  // bound is looser than a texel's own tile needs, never tighter.
  Eigen::Vector3d bound = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < terms.size(); ++k) bound += (terms[k] - last_sources_[k]).cwiseAbs().cast<double>();
  for (std::size_t i = 0; i < weights.face.size(); ++i) {
    bound += (weights.face[i] - last_face_[i]).cwiseAbs().cast<double>() *
             static_cast<double>(layer_max_[i % layer_max_.size()]);
  }
  return bound.maxCoeff() <= change_threshold_;
}

bool CpuBlender::blend(const blend::BlendWeights& weights, std::span<const float> sun_visibility,
                       std::uint64_t sun_revision, blend::BlendWorkers* workers) {
  return blend_sources(weights, sun_visibility, sun_revision, workers);
}

bool CpuBlender::blend_sources(const blend::BlendWeights& weights, std::span<const float> source_visibility,
                               std::uint64_t sun_revision, blend::BlendWorkers* workers) {
  std::vector<Eigen::Vector3f> terms = separated_terms(weights);
  if (unchanged_since_last(weights, terms, sun_revision)) return false;

  // skip_threshold: leave out the layers of least possible contribution while their bounds add
  // up to no more than the threshold (the GPU blender's rule, layer by layer).
  blend::BlendWeights used = weights;
  const std::size_t active = weights.active.size();
  std::vector<double> contribution(active);
  for (std::size_t a = 0; a < active; ++a) {
    const auto i = static_cast<std::size_t>(weights.active[a]);
    contribution[a] =
        static_cast<double>(weights.face[i].cwiseAbs().maxCoeff()) * static_cast<double>(layer_max_[i % layer_max_.size()]);
  }
  std::vector<std::size_t> order(active);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return contribution[a] < contribution[b]; });
  std::vector<bool> keep(active, true);
  double skipped = 0.0;
  int skipped_count = 0;
  for (const std::size_t a : order) {
    if (skipped + contribution[a] > skip_threshold_) break;
    skipped += contribution[a];
    keep[a] = false;
    ++skipped_count;
  }
  used.active.clear();
  for (std::size_t a = 0; a < active; ++a) {
    const int i = weights.active[a];
    if (keep[a]) {
      used.active.push_back(i);
    } else {
      used.face[static_cast<std::size_t>(i)].setZero();
    }
  }

  blend::BlendOptions options;
  options.workers = workers;
  const bool lit = any_lit(terms);
  if (terms.size() <= 1) {
    blend::blend_cpu(basis_, used, lit ? source_visibility : std::span<const float>(), rgb_, options);
  } else {
    // V_k of each source, one plane after another.
    const std::size_t texels = basis_.texel_count();
    std::vector<std::span<const float>> visibility;
    if (lit) {
      if (source_visibility.size() != terms.size() * texels) {
        throw InputError(input_message({}, -1, -1, "sun_visibility",
                                       std::to_string(source_visibility.size()) + " values for " +
                                           std::to_string(terms.size()) + " sources over plane '" + basis_.name +
                                           "' of " + std::to_string(texels) + " texels",
                                       "pass V of every separated source, the plane's texels source after source"));
      }
      for (std::size_t k = 0; k < terms.size(); ++k) visibility.push_back(source_visibility.subspan(k * texels, texels));
    }
    blend::blend_cpu_sources(basis_, used, visibility, rgb_, options);
  }
  auto rgba = std::make_shared<std::vector<float>>(4 * basis_.texel_count(), 1.0f);
  for (std::size_t k = 0; k < basis_.texel_count(); ++k) std::copy_n(rgb_.data() + 3 * k, 3, rgba->data() + 4 * k);
  rgba_ = std::move(rgba);

  has_result_ = true;
  last_face_ = weights.face;
  last_sources_ = std::move(terms);
  last_no_light_ = weights.no_light;
  last_sun_revision_ = lit ? sun_revision : 0;
  skipped_layers_ = skipped_count;
  return true;
}

}  // namespace skylit::blend
