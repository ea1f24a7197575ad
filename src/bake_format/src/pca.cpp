// compress_pca: the principal components of a plane's visible-fraction images (pca.hpp).
#include "skylit/bake_format/pca.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Imath/half.h>

#include "skylit/base/parallel_for.hpp"

namespace skylit::bake_format {
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

Eigen::MatrixXd sky_prior_root(std::span<const Vec3> directions, std::span<const double> weights, double sigma_deg) {
  const auto n = static_cast<Eigen::Index>(directions.size());
  const double sigma = sigma_deg * 3.14159265358979323846 / 180.0;
  Eigen::MatrixXd moments(n, n);
  for (Eigen::Index r = 0; r < n; ++r) {
    for (Eigen::Index c = 0; c < n; ++c) {
      const Vec3& a = directions[static_cast<std::size_t>(r)];
      const Vec3& b = directions[static_cast<std::size_t>(c)];
      const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
      const double w = weights.empty() ? 1.0 : weights[static_cast<std::size_t>(r)] * weights[static_cast<std::size_t>(c)];
      moments(r, c) = w * std::exp(-0.5 * angle * angle / (sigma * sigma));
    }
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> prior(moments);
  const Eigen::VectorXd roots = prior.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  Eigen::MatrixXd root = prior.eigenvectors() * roots.asDiagonal() * prior.eigenvectors().transpose();
  if (n > 0) root /= root.norm() / std::sqrt(static_cast<double>(n));  // scale is irrelevant; keep it near 1
  return root;
}

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
  if (options.tile < 0 || options.tile == 1) {
    throw std::invalid_argument("pca.tile: " + std::to_string(options.tile) +
                                " is not 0 (the whole plane) or a tile of at least 2 texels");
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

namespace {

// The components of one region (the whole plane, or one tile of it), and the sums of squares
// before and after (to combine tiles' variance fractions).
struct RegionPca {
  PcaBasis pca;
  double centred_squares = 0.0;
  double residual_squares = 0.0;
};

RegionPca compress_region(const ImageStack& stack, std::span<const double> unoccluded, const PcaOptions& options,
                          std::span<const Vec3> directions) {
  const std::size_t texels = static_cast<std::size_t>(stack.width) * static_cast<std::size_t>(stack.height);

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
    std::vector<Vec3> lit_directions;
    std::vector<double> lit_weights;
    for (const int l : lit) {
      lit_directions.push_back(directions[static_cast<std::size_t>(l)]);
      lit_weights.push_back(unoccluded[static_cast<std::size_t>(l)]);
    }
    mixing_root = sky_prior_root(lit_directions, lit_weights, options.sky_correlation_deg);
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
  return RegionPca{std::move(pca), centred.sum_squares, now.sum_squares};
}

// Layers of `stack` over texels [x0, x0 + w) × [y0, y0 + h).
ImageStack crop(const ImageStack& stack, int x0, int y0, int w, int h) {
  ImageStack out;
  out.width = w;
  out.height = h;
  out.layers = stack.layers;
  out.data.resize(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * static_cast<std::size_t>(stack.layers));
  for (int l = 0; l < stack.layers; ++l) {
    const std::span<const float> in = stack.layer(l);
    const std::span<float> to = out.layer(l);
    for (int y = 0; y < h; ++y) {
      const auto from = in.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y0 + y) * static_cast<std::size_t>(stack.width) +
                                                                 static_cast<std::size_t>(x0));
      std::copy(from, from + w, to.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(y) * static_cast<std::size_t>(w)));
    }
  }
  return out;
}

PcaBasis compress_tiles(const ImageStack& stack, std::span<const double> unoccluded, const PcaOptions& options,
                        std::span<const Vec3> directions) {
  PcaBasis pca;
  pca.width = stack.width;
  pca.height = stack.height;
  pca.source_layers = stack.layers;
  pca.tile = options.tile;
  const int tiles_x = pca.tiles_x(), tiles = pca.tile_count();
  const auto region = [&](int t) {
    const int x0 = (t % tiles_x) * options.tile, y0 = (t / tiles_x) * options.tile;
    return std::array<int, 4>{x0, y0, std::min(options.tile, stack.width - x0), std::min(options.tile, stack.height - y0)};
  };
  PcaOptions each = options;
  each.tile = 0;
  std::vector<RegionPca> parts(static_cast<std::size_t>(tiles));
  const auto compress_tile = [&](int t, const PcaOptions& o) {
    const auto [x0, y0, w, h] = region(t);
    parts[static_cast<std::size_t>(t)] = compress_region(crop(stack, x0, y0, w, h), unoccluded, o, directions);
  };
  parallel_for(tiles, 0, [&](int t) { compress_tile(t, each); });
  // One K for every tile: the tiles that met the criteria with fewer are compressed again to
  // K, which only lowers their error (a tile whose rank is below K keeps fewer, padded with zeros).
  int k = 0;
  for (const RegionPca& part : parts) k = std::max(k, part.pca.components);
  PcaOptions at_k = each;
  at_k.components = std::max(k, 1);
  std::vector<int> short_tiles;
  for (int t = 0; t < tiles; ++t) {
    if (parts[static_cast<std::size_t>(t)].pca.components < k) short_tiles.push_back(t);
  }
  parallel_for(static_cast<int>(short_tiles.size()), 0,
               [&](int i) { compress_tile(short_tiles[static_cast<std::size_t>(i)], at_k); });

  pca.components = k;
  pca.images.width = stack.width;
  pca.images.height = stack.height;
  pca.images.layers = k + 1;
  pca.images.data.assign(static_cast<std::size_t>(stack.width) * static_cast<std::size_t>(stack.height) *
                             static_cast<std::size_t>(k + 1),
                         0.0f);
  const auto n = static_cast<std::size_t>(stack.layers);
  pca.coefficients.assign(static_cast<std::size_t>(tiles) * n * static_cast<std::size_t>(k), 0.0f);
  double centred = 0.0, residual = 0.0;
  for (int t = 0; t < tiles; ++t) {
    const RegionPca& part = parts[static_cast<std::size_t>(t)];
    const auto [x0, y0, w, h] = region(t);
    for (int layer = 0; layer <= part.pca.components; ++layer) {
      const std::span<const float> from = part.pca.images.layer(layer);
      const std::span<float> to = pca.images.layer(layer);
      for (int y = 0; y < h; ++y) {
        std::copy_n(from.begin() + static_cast<std::ptrdiff_t>(y) * w, w,
                    to.begin() + static_cast<std::ptrdiff_t>(y0 + y) * stack.width + x0);
      }
    }
    const auto kt = static_cast<std::size_t>(part.pca.components);
    for (std::size_t l = 0; l < n; ++l) {
      for (std::size_t c = 0; c < kt; ++c) {
        pca.coefficients[(static_cast<std::size_t>(t) * n + l) * static_cast<std::size_t>(k) + c] = part.pca.coefficients[l * kt + c];
      }
    }
    pca.max_error = std::max(pca.max_error, part.pca.max_error);
    centred += part.centred_squares;
    residual += part.residual_squares;
    for (std::size_t r = 0; r < part.pca.eigenvalues.size(); ++r) {
      if (pca.eigenvalues.size() <= r) pca.eigenvalues.push_back(0.0);
      pca.eigenvalues[r] += part.pca.eigenvalues[r];
    }
  }
  std::size_t lit = 0;
  for (const double a : unoccluded) lit += a > 0.0 ? 1 : 0;
  const double values = static_cast<double>(lit) * static_cast<double>(stack.width) * static_cast<double>(stack.height);
  pca.rms_error = values > 0.0 ? std::sqrt(residual / values) : 0.0;
  pca.variance_kept = centred > 0.0 ? 1.0 - residual / centred : 1.0;
  return pca;
}

}  // namespace

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
  if (options.sky_correlation_deg > 0.0 && directions.size() != static_cast<std::size_t>(stack.layers)) {
    throw std::invalid_argument("compress_pca: a sky prior needs one direction per layer");
  }
  if (options.tile > 0 && (options.tile < stack.width || options.tile < stack.height)) {
    return compress_tiles(stack, unoccluded, options, directions);
  }
  PcaOptions whole = options;
  whole.tile = 0;
  return compress_region(stack, unoccluded, whole, directions).pca;
}

}  // namespace skylit::bake_format
