// compress_pca: the principal components of a plane's visible-fraction images (pca.hpp).
#include "skylit/bake/pca.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Imath/half.h>

namespace skylit::bake {
namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

float round_to_half(float value) { return static_cast<float>(Imath::half(value)); }

struct ResidualStats {
  double max_abs = 0.0;
  double sum_squares = 0.0;
};

ResidualStats residual_stats(const RowMatrix& residual) {
  ResidualStats s;
  s.max_abs = residual.size() ? static_cast<double>(residual.cwiseAbs().maxCoeff()) : 0.0;
  s.sum_squares = residual.cast<double>().squaredNorm();
  return s;
}

}  // namespace

void check_pca_options(const PcaOptions& options) {
  if (!options.components && !options.variance && !options.max_error) {
    throw std::invalid_argument("pca: give at least one of components, variance and max_error");
  }
  if (options.components && *options.components < 1) {
    throw std::invalid_argument("pca.components: " + std::to_string(*options.components) + " is not >= 1");
  }
  if (options.variance && !(*options.variance > 0.0 && *options.variance <= 1.0)) {
    throw std::invalid_argument("pca.variance: " + std::to_string(*options.variance) + " is not in (0, 1]");
  }
  if (!(options.sky_correlation_deg >= 0.0 && std::isfinite(options.sky_correlation_deg))) {
    throw std::invalid_argument("pca.sky_correlation_deg: " + std::to_string(options.sky_correlation_deg) +
                                " is not a finite angle >= 0");
  }
  if (options.max_error && !(*options.max_error > 0.0 && std::isfinite(*options.max_error))) {
    throw std::invalid_argument("pca.max_error: " + std::to_string(*options.max_error) + " is not a finite value > 0");
  }
}

std::vector<std::string> pca_layer_names(int components) {
  std::vector<std::string> names{"mean"};
  for (int k = 1; k <= components; ++k) {
    char name[16];
    std::snprintf(name, sizeof name, "pc_%03d", k);
    names.emplace_back(name);
  }
  return names;
}

PcaBasis compress_pca(const ImageStack& stack, std::span<const double> unoccluded, const PcaOptions& options,
                      std::span<const Vec3> directions) {
  check_pca_options(options);
  const std::size_t texels = static_cast<std::size_t>(stack.width) * static_cast<std::size_t>(stack.height);
  if (stack.width <= 0 || stack.height <= 0 || stack.layers < 0 ||
      stack.data.size() != texels * static_cast<std::size_t>(stack.layers)) {
    throw std::invalid_argument("compress_pca: the stack's size does not match its data");
  }
  if (unoccluded.size() != static_cast<std::size_t>(stack.layers)) {
    throw std::invalid_argument("compress_pca: " + std::to_string(unoccluded.size()) + " unoccluded values for " +
                                std::to_string(stack.layers) + " layers");
  }

  // The fractions F_l of the layers with light, from B rounded to half floats as the bake
  // stores it: the full blend the compressed one is measured against reads those.
  std::vector<int> lit;
  for (int l = 0; l < stack.layers; ++l) {
    if (unoccluded[static_cast<std::size_t>(l)] > 0.0) lit.push_back(l);
  }
  const Eigen::Index rows = static_cast<Eigen::Index>(lit.size());
  const Eigen::Index cols = static_cast<Eigen::Index>(texels);
  RowMatrix residual(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const int l = lit[static_cast<std::size_t>(r)];
    const float inverse_a = static_cast<float>(1.0 / unoccluded[static_cast<std::size_t>(l)]);
    const std::span<const float> b = stack.layer(l);
    for (Eigen::Index x = 0; x < cols; ++x) {
      residual(r, x) = round_to_half(b[static_cast<std::size_t>(x)]) * inverse_a;
    }
  }

  PcaBasis pca;
  pca.width = stack.width;
  pca.height = stack.height;
  pca.source_layers = stack.layers;

  // The mean, stored as half floats; the residual is taken from the stored mean so that the
  // reconstruction below is exactly what the blend will compute.
  Eigen::VectorXf mean = Eigen::VectorXf::Zero(cols);
  if (rows > 0) mean = (residual.cast<double>().colwise().sum() / static_cast<double>(rows)).cast<float>().transpose();
  for (Eigen::Index x = 0; x < cols; ++x) mean[x] = round_to_half(mean[x]);
  residual.rowwise() -= mean.transpose();
  const ResidualStats centred = residual_stats(residual);

  // Eigenvectors of the layers' Gram matrix (rows × rows, accumulated in double over blocks of
  // texels): the eigen-images are residual^T v.
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(rows, rows);
  constexpr Eigen::Index kBlock = 8192;
  for (Eigen::Index x0 = 0; x0 < cols; x0 += kBlock) {
    const Eigen::Index width = std::min(kBlock, cols - x0);
    const auto block = residual.middleCols(x0, width);
    gram += (block * block.transpose()).cast<double>();
  }
  // With a sky prior the components are those of F·W, W = C^{1/2} for the second moments C of
  // the weights α a sky puts on the layers: the images that matter for skies, not for single
  // faces. The mixing vectors W v_k (v_k eigenvectors of W G W) make the images.
  Eigen::MatrixXd mixing_root = Eigen::MatrixXd::Identity(rows, rows);
  if (options.sky_correlation_deg > 0.0 && rows > 0) {
    if (directions.size() != static_cast<std::size_t>(stack.layers)) {
      throw std::invalid_argument("compress_pca: a sky prior needs one direction per layer");
    }
    const double sigma = options.sky_correlation_deg * 3.14159265358979323846 / 180.0;
    Eigen::MatrixXd moments(rows, rows);
    for (Eigen::Index r = 0; r < rows; ++r) {
      for (Eigen::Index c = 0; c < rows; ++c) {
        const auto lr = static_cast<std::size_t>(lit[static_cast<std::size_t>(r)]);
        const auto lc = static_cast<std::size_t>(lit[static_cast<std::size_t>(c)]);
        const double angle = std::atan2(directions[lr].cross(directions[lc]).norm(), directions[lr].dot(directions[lc]));
        moments(r, c) = unoccluded[lr] * unoccluded[lc] * std::exp(-0.5 * angle * angle / (sigma * sigma));
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> prior(moments);
    const Eigen::VectorXd roots = prior.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    mixing_root = prior.eigenvectors() * roots.asDiagonal() * prior.eigenvectors().transpose();
    mixing_root /= mixing_root.norm() / std::sqrt(static_cast<double>(rows));  // scale is irrelevant; keep it near 1
  }
  std::vector<Eigen::VectorXd> eigenvectors;
  if (rows > 0) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(mixing_root * gram * mixing_root);
    for (Eigen::Index k = rows - 1; k >= 0; --k) {
      pca.eigenvalues.push_back(std::max(0.0, solver.eigenvalues()[k]));
      eigenvectors.push_back(mixing_root * solver.eigenvectors().col(k));
    }
  }
  // Components beyond the numerical rank carry rounding noise, not shadows.
  const double largest = pca.eigenvalues.empty() ? 0.0 : pca.eigenvalues.front();
  int rank = 0;
  while (rank < static_cast<int>(pca.eigenvalues.size()) &&
         pca.eigenvalues[static_cast<std::size_t>(rank)] > 1e-12 * largest && largest > 0.0) {
    ++rank;
  }

  std::vector<Eigen::VectorXf> components;   // stored (half-rounded, scaled) eigen-images
  std::vector<Eigen::VectorXf> coefficients;  // per component: P_{r,k} over the lit rows
  ResidualStats now = centred;
  const auto satisfied = [&](int k) {
    if (options.components && k < *options.components) return false;
    if (options.variance && centred.sum_squares > 0.0 &&
        1.0 - now.sum_squares / centred.sum_squares < *options.variance - 1e-12) {
      return false;
    }
    if (options.max_error && now.max_abs > *options.max_error) return false;
    return true;
  };
  for (int k = 0; k < rank && !satisfied(k); ++k) {
    // Taken from the residual (deflated): the same image for an exact eigenvector, and free of
    // what the components before it already hold.
    Eigen::VectorXf image = (eigenvectors[static_cast<std::size_t>(k)].cast<float>().transpose() * residual).transpose();
    const float top = image.cwiseAbs().maxCoeff();
    if (!(top > 0.0f)) break;
    image /= top;
    for (Eigen::Index x = 0; x < cols; ++x) image[x] = round_to_half(image[x]);
    const double norm2 = image.cast<double>().squaredNorm();
    if (!(norm2 > 0.0)) break;
    Eigen::VectorXd projection = Eigen::VectorXd::Zero(rows);  // in double, a block of texels at a time
    for (Eigen::Index x0 = 0; x0 < cols; x0 += kBlock) {
      const Eigen::Index width = std::min(kBlock, cols - x0);
      projection += (residual.middleCols(x0, width) * image.segment(x0, width)).cast<double>();
    }
    const Eigen::VectorXf p = (projection / norm2).cast<float>();
    residual.noalias() -= p * image.transpose();
    now = residual_stats(residual);
    components.push_back(std::move(image));
    coefficients.push_back(p);
  }

  pca.components = static_cast<int>(components.size());
  pca.images.width = stack.width;
  pca.images.height = stack.height;
  pca.images.layers = pca.components + 1;
  pca.images.data.resize(texels * static_cast<std::size_t>(pca.images.layers));
  std::copy(mean.data(), mean.data() + cols, pca.images.layer(0).begin());
  for (int k = 0; k < pca.components; ++k) {
    const Eigen::VectorXf& image = components[static_cast<std::size_t>(k)];
    std::copy(image.data(), image.data() + cols, pca.images.layer(k + 1).begin());
  }
  pca.coefficients.assign(static_cast<std::size_t>(stack.layers) * static_cast<std::size_t>(pca.components), 0.0f);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const auto l = static_cast<std::size_t>(lit[static_cast<std::size_t>(r)]);
    for (int k = 0; k < pca.components; ++k) {
      pca.coefficients[l * static_cast<std::size_t>(pca.components) + static_cast<std::size_t>(k)] =
          coefficients[static_cast<std::size_t>(k)][r];
    }
  }
  pca.max_error = now.max_abs;
  pca.rms_error = rows > 0 ? std::sqrt(now.sum_squares / (static_cast<double>(rows) * static_cast<double>(cols))) : 0.0;
  pca.variance_kept = centred.sum_squares > 0.0 ? 1.0 - now.sum_squares / centred.sum_squares : 1.0;
  return pca;
}

}  // namespace skylit::bake
