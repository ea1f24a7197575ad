// The light map's PCA form: its compression chart by chart, and its files (light_map.hpp).
#include "skylit/bake_format/light_map.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "skylit/bake_format/arrays.hpp"
#include "skylit/bake_format/pca.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/parallel_for.hpp"

namespace skylit::bake_format {
namespace fs = std::filesystem;

namespace {

using FloatRows = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct ChartResult {
  double squared_error = 0.0, max_error = 0.0, squared_value = 0.0;
};

// One chart: its texels' rows of `transfer`, its mean and K components into `out`.
ChartResult compress_chart(std::span<const std::size_t> rows, std::span<const float> transfer, std::size_t layers, int components,
                           const Eigen::MatrixXd* root, std::size_t chart, LightMapComponents& out) {
  const auto n = static_cast<Eigen::Index>(rows.size());
  const auto L = static_cast<Eigen::Index>(layers);
  const auto K = static_cast<std::size_t>(components);
  FloatRows X(n, L);
  for (Eigen::Index i = 0; i < n; ++i) {
    const float* t = transfer.data() + rows[static_cast<std::size_t>(i)] * layers;
    for (Eigen::Index l = 0; l < L; ++l) X(i, l) = std::isfinite(t[l]) && t[l] > 0.0f ? t[l] : 0.0f;
  }
  ChartResult result;
  result.squared_value = X.cast<double>().squaredNorm();
  const Eigen::RowVectorXf mean = (X.cast<double>().colwise().sum() / static_cast<double>(std::max<Eigen::Index>(n, 1))).cast<float>();
  FloatRows R = X.rowwise() - mean;

  // The leading left singular vectors of R W (W the prior's root, or none): from the n × n Gram
  // R C Rᵀ on a small chart, from W Rᵀ R W on a large one (u = R W v / |R W v|).
  std::vector<Eigen::VectorXd> basis;
  if (n > 0) {
    const Eigen::MatrixXd Rd = R.cast<double>();
    const Eigen::Index keep = std::min<Eigen::Index>(static_cast<Eigen::Index>(K), std::min(n, L));
    std::vector<Eigen::VectorXd> candidates;
    if (n <= L) {
      const Eigen::MatrixXd weighted = root ? Eigen::MatrixXd(Rd * *root) : Rd;
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(weighted * weighted.transpose());
      for (Eigen::Index k = 0; k < keep; ++k) candidates.push_back(solver.eigenvectors().col(n - 1 - k));
    } else {
      const Eigen::MatrixXf gram = R.transpose() * R;  // float GEMM: the bulk of the work
      const Eigen::MatrixXd g = gram.cast<double>();
      const Eigen::MatrixXd weighted = root ? Eigen::MatrixXd(*root * g * *root) : g;
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(weighted);
      for (Eigen::Index k = 0; k < keep; ++k) {
        const Eigen::VectorXd v = solver.eigenvectors().col(L - 1 - k);
        candidates.push_back(root ? Eigen::VectorXd(Rd * (*root * v)) : Eigen::VectorXd(Rd * v));
      }
    }
    // Orthonormal (Gram–Schmidt twice), so that Σ u uᵀ R is the projection; a direction that is
    // numerically inside the others' span is dropped.
    const double scale = std::max(Rd.norm(), 1e-30);
    for (Eigen::VectorXd u : candidates) {
      for (int pass = 0; pass < 2; ++pass) {
        for (const Eigen::VectorXd& b : basis) u -= b.dot(u) * b;
      }
      const double norm = u.norm();
      if (!(norm > 0.0)) continue;
      u /= norm;
      if ((u.transpose() * Rd).norm() <= 1e-7 * scale) continue;
      basis.push_back(std::move(u));
    }
  }

  // Stored: a_{x,k} = u_k(x) and p_k = Rᵀ u_k; the residual measured from the stored floats.
  float* vectors = out.vectors.data() + chart * (K + 1) * layers;
  std::copy(mean.data(), mean.data() + L, vectors);
  FloatRows residual = R;
  for (std::size_t k = 0; k < basis.size(); ++k) {
    const Eigen::VectorXf u = basis[k].cast<float>();
    const Eigen::RowVectorXf p = (u.transpose().cast<double>() * R.cast<double>()).cast<float>();
    std::copy(p.data(), p.data() + L, vectors + (k + 1) * layers);
    for (Eigen::Index i = 0; i < n; ++i) out.weights[rows[static_cast<std::size_t>(i)] * K + k] = u[i];
    residual.noalias() -= u * p;
  }
  result.squared_error = residual.cast<double>().squaredNorm();
  result.max_error = residual.size() ? static_cast<double>(residual.cwiseAbs().maxCoeff()) : 0.0;
  return result;
}

[[noreturn]] void bad_pca(const fs::path& file, const std::string& field, const std::string& problem) {
  throw InputError(input_message(file, -1, -1, field, problem, "add the form again with skylit-bake compress BAKE_DIR --light-map-components K"));
}

}  // namespace

void check_light_map_pca_options(const LightMapPcaOptions& options) {
  if (options.components < 1 || options.components > 4096) {
    throw std::invalid_argument("light_map_pca.components: " + std::to_string(options.components) + " is not in [1, 4096]");
  }
  if (!(options.sky_correlation_deg >= 0.0 && std::isfinite(options.sky_correlation_deg))) {
    throw std::invalid_argument("light_map_pca.sky_correlation_deg: " + std::to_string(options.sky_correlation_deg) +
                                " is not a finite angle >= 0");
  }
}

std::vector<std::int32_t> light_map_texel_charts(const LightMapLayout& layout) {
  std::vector<std::int32_t> chart_of(layout.texels.size(), -1);
  const auto width = static_cast<std::uint64_t>(layout.width);
  for (std::size_t c = 0; c < layout.charts.size(); ++c) {
    const LightMapChart& chart = layout.charts[c];
    for (int row = chart.y; row < chart.y + chart.height; ++row) {
      const std::uint64_t first = static_cast<std::uint64_t>(row) * width + static_cast<std::uint64_t>(chart.x);
      auto it = std::lower_bound(layout.texels.begin(), layout.texels.end(), first);
      for (; it != layout.texels.end() && *it < first + static_cast<std::uint64_t>(chart.width); ++it) {
        chart_of[static_cast<std::size_t>(it - layout.texels.begin())] = static_cast<std::int32_t>(c);
      }
    }
  }
  return chart_of;
}

LightMapComponents compress_light_map(const LightMapLayout& layout, std::span<const float> transfer, std::size_t layers,
                                      const LightMapPcaOptions& options, std::span<const Vec3> directions) {
  check_light_map_pca_options(options);
  if (layers == 0 || transfer.size() != layout.texels.size() * layers) {
    throw std::invalid_argument("compress_light_map: " + std::to_string(transfer.size()) + " transfer values for " +
                                std::to_string(layout.texels.size()) + " texels of " + std::to_string(layers) + " layers");
  }
  if (options.sky_correlation_deg > 0.0 && directions.size() != layers) {
    throw std::invalid_argument("compress_light_map: a sky prior needs one direction per layer");
  }
  const std::vector<std::int32_t> chart_of = light_map_texel_charts(layout);
  std::vector<std::vector<std::size_t>> members(layout.charts.size());
  for (std::size_t x = 0; x < chart_of.size(); ++x) {
    if (chart_of[x] < 0) throw std::invalid_argument("compress_light_map: texel " + std::to_string(x) + " lies on no chart");
    members[static_cast<std::size_t>(chart_of[x])].push_back(x);
  }
  LightMapComponents out;
  out.components = options.components;
  out.layers = layers;
  const auto K = static_cast<std::size_t>(options.components);
  out.weights.assign(layout.texels.size() * K, 0.0f);
  out.vectors.assign(layout.charts.size() * (K + 1) * layers, 0.0f);
  const std::optional<Eigen::MatrixXd> root =
      options.sky_correlation_deg > 0.0 ? std::optional<Eigen::MatrixXd>(sky_prior_root(directions, {}, options.sky_correlation_deg)) : std::nullopt;

  // The largest charts first, so that the threads finish together.
  std::vector<std::size_t> order(layout.charts.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return members[a].size() > members[b].size(); });
  std::vector<ChartResult> results(order.size());
  parallel_for(static_cast<int>(order.size()), 0, [&](int i) {
    const std::size_t c = order[static_cast<std::size_t>(i)];
    results[c] = compress_chart(members[c], transfer, layers, options.components, root ? &*root : nullptr, c, out);
  });
  double squared_error = 0.0, squared_value = 0.0;
  for (const ChartResult& r : results) {
    squared_error += r.squared_error;
    squared_value += r.squared_value;
    out.max_error = std::max(out.max_error, r.max_error);
  }
  const double values = static_cast<double>(transfer.size());
  out.rms_error = values > 0.0 ? std::sqrt(squared_error / values) : 0.0;
  out.rms_value = values > 0.0 ? std::sqrt(squared_value / values) : 0.0;
  return out;
}

std::vector<float> expand_light_map(const LightMapLayout& layout, const LightMapComponents& c) {
  const std::vector<std::int32_t> chart_of = light_map_texel_charts(layout);
  const std::size_t L = c.layers, K = static_cast<std::size_t>(c.components);
  std::vector<float> out(chart_of.size() * L);
  for (std::size_t x = 0; x < chart_of.size(); ++x) {
    const float* vectors = c.vectors.data() + static_cast<std::size_t>(chart_of[x]) * (K + 1) * L;
    float* t = out.data() + x * L;
    std::copy(vectors, vectors + L, t);
    for (std::size_t k = 0; k < K; ++k) {
      const float a = c.weights[x * K + k];
      for (std::size_t l = 0; l < L; ++l) t[l] += a * vectors[(k + 1) * L + l];
    }
  }
  return out;
}

void write_light_map_pca(const fs::path& bake_dir, const Manifest::LightMap::Pca& record, const LightMapPca& pca) {
  const auto write = [&](const std::string& weights_file, const std::string& vectors_file, const LightMapComponents& c) {
    const std::size_t K = static_cast<std::size_t>(c.components);
    const std::size_t texels = K > 0 ? c.weights.size() / K : 0;
    const std::size_t charts = c.vectors.size() / ((K + 1) * c.layers);
    const std::size_t weights_shape[] = {texels, K};
    const std::size_t vectors_shape[] = {charts, K + 1, c.layers};
    write_npy(bake_dir / weights_file, c.weights, weights_shape);
    write_npy(bake_dir / vectors_file, c.vectors, vectors_shape);
  };
  write(record.weights_file, record.vectors_file, pca.sky);
  if (!record.ground_weights_file.empty()) write(record.ground_weights_file, record.ground_vectors_file, pca.ground);
}

LightMapPca read_light_map_pca(const fs::path& bake_dir, const Manifest& manifest, const LightMapLayout& layout) {
  if (!manifest.light_map || !manifest.light_map->pca) {
    throw InputError(input_message(bake_dir / "manifest.json", -1, -1, "light_map.pca", "is missing",
                                   "add it with skylit-bake compress BAKE_DIR --light-map-components K"));
  }
  const Manifest::LightMap::Pca& record = *manifest.light_map->pca;
  const auto K = static_cast<std::size_t>(record.components);
  const std::size_t L = manifest.layer_count();
  const auto read = [&](const std::string& weights_file, const std::string& vectors_file) {
    LightMapComponents c;
    c.components = record.components;
    c.layers = L;
    std::vector<std::size_t> shape;
    c.weights = read_npy(bake_dir / weights_file, &shape);
    if (c.weights.size() != layout.texels.size() * K) {
      bad_pca(bake_dir / weights_file, "shape", "must be [" + std::to_string(layout.texels.size()) + ", " + std::to_string(K) + "]");
    }
    c.vectors = read_npy(bake_dir / vectors_file, &shape);
    if (c.vectors.size() != layout.charts.size() * (K + 1) * L) {
      bad_pca(bake_dir / vectors_file, "shape",
              "must be [" + std::to_string(layout.charts.size()) + ", " + std::to_string(K + 1) + ", " + std::to_string(L) + "]");
    }
    for (const std::vector<float>* values : {&c.weights, &c.vectors}) {
      if (!std::all_of(values->begin(), values->end(), [](float v) { return std::isfinite(v); })) {
        bad_pca(bake_dir / (values == &c.weights ? weights_file : vectors_file), "values", "holds a value that is not finite");
      }
    }
    return c;
  };
  LightMapPca pca;
  pca.sky = read(record.weights_file, record.vectors_file);
  pca.sky.rms_error = record.rms_error;
  pca.sky.max_error = record.max_error;
  if (!record.ground_weights_file.empty()) {
    pca.ground = read(record.ground_weights_file, record.ground_vectors_file);
    pca.ground.rms_error = record.ground_rms_error;
    pca.ground.max_error = record.ground_max_error;
  }
  return pca;
}

}  // namespace skylit::bake_format
