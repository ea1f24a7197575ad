// The light map's PCA form: a chart's transfer of rank K comes back exactly with K components,
// below that the error is what the dropped singular values say (the best rank-K fit), with or
// without the sky prior; its files round-trip through the manifest.
#include <cmath>
#include <cstdio>
#include <random>

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "skylit/bake_format/light_map.hpp"
#include "skylit/base/error.hpp"
#include "bake_fixtures.hpp"

namespace skylit::bake_format {
namespace light_map_pca_test {  // named: the test program is one unity build

// A 10 × 4 atlas of two charts, 4 × 4 at (0, 0) and 5 × 3 at (5, 1); every texel of the charts
// traced, the atlas's other texels not.
LightMapLayout two_charts() {
  LightMapLayout l;
  l.texel = 0.1;
  l.width = 10;
  l.height = 4;
  LightMapChart a;
  a.width = a.height = 4;
  a.texel_u = a.texel_v = 0.1;
  LightMapChart b = a;
  b.x = 5, b.y = 1, b.width = 5, b.height = 3;
  l.charts = {a, b};
  for (int row = 0; row < l.height; ++row) {
    for (int column = 0; column < l.width; ++column) {
      if ((column < 4) || (column >= 5 && row >= 1)) l.texels.push_back(static_cast<std::uint32_t>(row * l.width + column));
    }
  }
  return l;
}

// Per chart a mean plus `ranks[c]` random directions over `layers`, positive everywhere.
std::vector<float> transfer_of_rank(const LightMapLayout& l, std::size_t layers, const std::vector<int>& ranks, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const std::vector<std::int32_t> chart = light_map_texel_charts(l);
  std::vector<Eigen::MatrixXd> directions;
  for (const int r : ranks) {
    Eigen::MatrixXd d(r + 1, static_cast<Eigen::Index>(layers));
    for (Eigen::Index i = 0; i < d.size(); ++i) d.data()[i] = uniform(rng);
    directions.push_back(d);
  }
  std::vector<float> t(l.texels.size() * layers);
  for (std::size_t x = 0; x < l.texels.size(); ++x) {
    const Eigen::MatrixXd& d = directions[static_cast<std::size_t>(chart[x])];
    Eigen::RowVectorXd v = 3.0 * Eigen::RowVectorXd::Ones(static_cast<Eigen::Index>(layers)) + 0.5 * d.row(0);
    for (Eigen::Index k = 1; k < d.rows(); ++k) v += 0.4 * uniform(rng) * d.row(k);
    for (std::size_t j = 0; j < layers; ++j) t[x * layers + j] = static_cast<float>(0.01 * v[static_cast<Eigen::Index>(j)]);
  }
  return t;
}

// Σ over charts of the squared singular values of each chart's centred transfer beyond the K-th.
double dropped_squares(const LightMapLayout& l, const std::vector<float>& t, std::size_t layers, int K) {
  const std::vector<std::int32_t> chart = light_map_texel_charts(l);
  double sum = 0.0;
  for (std::int32_t c = 0; c < static_cast<std::int32_t>(l.charts.size()); ++c) {
    std::vector<std::size_t> rows;
    for (std::size_t x = 0; x < chart.size(); ++x) {
      if (chart[x] == c) rows.push_back(x);
    }
    Eigen::MatrixXd X(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(layers));
    for (std::size_t i = 0; i < rows.size(); ++i) {
      for (std::size_t j = 0; j < layers; ++j) X(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = t[rows[i] * layers + j];
    }
    X.rowwise() -= X.colwise().mean();
    const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(X).singularValues();
    for (Eigen::Index k = K; k < s.size(); ++k) sum += s[k] * s[k];
  }
  return sum;
}

std::vector<Vec3> spread_directions(std::size_t layers) {
  std::vector<Vec3> d;
  for (std::size_t j = 0; j < layers; ++j) {
    const double azimuth = 2.399963 * static_cast<double>(j), z = (static_cast<double>(j) + 0.5) / static_cast<double>(layers);
    const double r = std::sqrt(1.0 - z * z);
    d.emplace_back(r * std::cos(azimuth), r * std::sin(azimuth), z);
  }
  return d;
}

TEST(LightMapPca, AChartsTransferOfRankKComesBackExactlyAndBelowItTheErrorIsTheDroppedSingularValues) {
  const LightMapLayout l = two_charts();
  const std::vector<std::int32_t> chart = light_map_texel_charts(l);
  ASSERT_EQ(chart.size(), 31u);
  EXPECT_EQ(std::count(chart.begin(), chart.end(), 0), 16);
  EXPECT_EQ(std::count(chart.begin(), chart.end(), 1), 15);
  // More layers than a chart has texels (the n × n route) and fewer (the layers' route).
  for (const std::size_t layers : {std::size_t{40}, std::size_t{9}}) {
    const std::vector<float> t = transfer_of_rank(l, layers, {3, 2}, 7);
    for (const double sigma : {0.0, 45.0}) {
      const LightMapComponents exact = compress_light_map(l, t, layers, {3, sigma}, spread_directions(layers));
      const std::vector<float> back = expand_light_map(l, exact);
      double worst = 0.0;
      for (std::size_t i = 0; i < t.size(); ++i) worst = std::max(worst, std::abs(double(back[i]) - t[i]));
      EXPECT_LT(worst, 2e-7) << layers << " layers, σ " << sigma;
      EXPECT_NEAR(exact.max_error, worst, 2e-7);
      EXPECT_GT(exact.rms_value, 0.02);
    }
    // One component: plain PCA is the best rank-1 fit, its residual the dropped singular values.
    const LightMapComponents one = compress_light_map(l, t, layers, {1, 0.0});
    const double expected = std::sqrt(dropped_squares(l, t, layers, 1) / static_cast<double>(t.size()));
    std::printf("measured: %zu layers, K = 1: RMS %.4g, the dropped singular values' %.4g\n", layers, one.rms_error, expected);
    EXPECT_GT(one.rms_error, 1e-4);
    EXPECT_NEAR(one.rms_error, expected, 1e-3 * expected);
    const std::vector<float> back = expand_light_map(l, one);
    double squares = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) squares += (double(back[i]) - t[i]) * (double(back[i]) - t[i]);
    EXPECT_NEAR(std::sqrt(squares / static_cast<double>(t.size())), one.rms_error, 1e-6);
    // With the prior the fit favours smooth skies: never better than plain PCA in the plain norm.
    const LightMapComponents prior = compress_light_map(l, t, layers, {1, 30.0}, spread_directions(layers));
    EXPECT_GE(prior.rms_error, one.rms_error * (1.0 - 1e-6));
  }
  // Values not finite or negative count as 0, as in the compositor's sum of the full form.
  std::vector<float> t = transfer_of_rank(l, 9, {1, 1}, 3);
  t[5] = -1.0f;
  t[6] = std::nanf("");
  std::vector<float> cleaned = t;
  cleaned[5] = cleaned[6] = 0.0f;
  const std::vector<float> a = expand_light_map(l, compress_light_map(l, t, 9, {20, 0.0}));
  const std::vector<float> b = expand_light_map(l, compress_light_map(l, cleaned, 9, {20, 0.0}));
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], cleaned[i], 1e-6) << i;
  EXPECT_EQ(a, b);
  // Bad options and sizes.
  EXPECT_THROW(compress_light_map(l, t, 9, {0, 0.0}), std::invalid_argument);
  EXPECT_THROW(compress_light_map(l, t, 9, {2, -1.0}), std::invalid_argument);
  EXPECT_THROW(compress_light_map(l, t, 9, {2, 45.0}), std::invalid_argument) << "a prior needs the layers' directions";
  EXPECT_THROW(compress_light_map(l, t, 8, {2, 0.0}), std::invalid_argument);
}

TEST(LightMapPca, ItsFilesRoundTripAndAShortFileIsRefusedByName) {
  test::TempDir dir("skylit-light-map-pca-");
  const LightMapLayout l = two_charts();
  const std::size_t layers = 6;
  LightMapPca pca;
  pca.sky = compress_light_map(l, transfer_of_rank(l, layers, {2, 1}, 1), layers, {2, 0.0});
  pca.ground = compress_light_map(l, transfer_of_rank(l, layers, {1, 1}, 2), layers, {2, 0.0});
  Manifest m;
  m.plan.light_map.texels = l.texels.size();
  m.plan.light_map.texel = 0.1;
  m.faces.resize(layers);  // the faces basis: one layer per face
  Manifest::LightMap record;
  record.chart_count = l.charts.size();
  Manifest::LightMap::Pca p;
  p.components = 2;
  p.ground_weights_file = "light_map_pca_ground_weights.npy";
  p.ground_vectors_file = "light_map_pca_ground_vectors.npy";
  p.rms_error = pca.sky.rms_error;
  record.pca = p;
  m.light_map = record;
  write_light_map_pca(dir.path(), p, pca);
  const LightMapPca back = read_light_map_pca(dir.path(), m, l);
  EXPECT_EQ(back.sky.weights, pca.sky.weights);
  EXPECT_EQ(back.sky.vectors, pca.sky.vectors);
  EXPECT_EQ(back.ground.vectors, pca.ground.vectors);
  EXPECT_EQ(back.sky.rms_error, pca.sky.rms_error);
  // A file of another shape: named, with the fix.
  const std::size_t shape[] = {3, 2};
  write_npy(dir.path() / p.weights_file, std::vector<float>(6, 0.0f), shape);
  try {
    read_light_map_pca(dir.path(), m, l);
    FAIL() << "a short weights file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("light_map_pca_weights.npy"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--light-map-components"), std::string::npos) << e.what();
  }
}

// The atlas as the compositor sums each form: the full form's t with a negative (or NaN) value
// taken as 0, the PCA form's t̂ as they are (a fit may dip below 0) with the sum clamped at 0.
TEST(LightMapPca, TheAtlasTakesTheFullFormsValuesCleanedAndThePcaFormsAsTheyAre) {
  const LightMapLayout l = two_charts();
  constexpr std::size_t kLayers = 2;
  std::vector<float> t(l.texels.size() * kLayers, 0.5f);
  t[0] = -0.1f;  // texel 0: t̂ = (−0.1, 0.5)
  t[2] = -1.0f;  // texel 1: t̂ = (−1, 0.5)
  t[5] = std::nanf("");  // texel 2: (0.5, NaN)
  const std::vector<Eigen::Vector3d> S{Eigen::Vector3d(1.0, 2.0, 0.0), Eigen::Vector3d::Ones()};
  const std::vector<Eigen::Vector3d> full = light_map_atlas(l, t, S);
  const std::vector<Eigen::Vector3d> pca = light_map_atlas(l, t, S, LightMapValues::Reconstructed);
  const auto at = [&](const std::vector<Eigen::Vector3d>& atlas, std::size_t texel) { return atlas[l.texels[texel]]; };
  EXPECT_TRUE(at(full, 0).isApprox(Eigen::Vector3d(0.5, 0.5, 0.5), 1e-6));
  EXPECT_TRUE(at(pca, 0).isApprox(Eigen::Vector3d(0.4, 0.3, 0.5), 1e-6));
  EXPECT_TRUE(at(full, 1).isApprox(Eigen::Vector3d(0.5, 0.5, 0.5), 1e-6));
  EXPECT_TRUE(at(pca, 1).isApprox(Eigen::Vector3d(0.0, 0.0, 0.5), 1e-6)) << at(pca, 1).transpose();
  EXPECT_TRUE(at(full, 2).isApprox(Eigen::Vector3d(0.5, 1.0, 0.0), 1e-6));
  EXPECT_TRUE(at(pca, 2).isApprox(Eigen::Vector3d(0.5, 1.0, 0.0), 1e-6));
  EXPECT_TRUE(at(pca, 3).isApprox(Eigen::Vector3d(1.0, 1.5, 0.5), 1e-6));
}

}  // namespace light_map_pca_test
}  // namespace skylit::bake_format
