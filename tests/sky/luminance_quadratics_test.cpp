// The quadratics basis in the sky stage: six quadratic Bernstein functions per face, fitted by
// least squares to the face's pixels, with the linear fit where the pixels pin down only three.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../support/lens_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace luminance_quadratics_test {  // named, not anonymous: the test program is one unity build

using lens_testing::dome;
using lens_testing::frame_of;
using lens_testing::sample_lens;
using Rgb = Eigen::Vector3d;

const SkyTable& table_of(int frequency, int step, geom::DomeBasis basis) {
  static std::map<std::tuple<int, int, geom::DomeBasis>, SkyTable> cache;
  const auto key = std::make_tuple(frequency, step, basis);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, build_sky_table(sample_lens(), dome(frequency), {step, basis})).first;
  return it->second;
}
const SkyTable& quadratics_table(int frequency, int step) {
  return table_of(frequency, step, geom::DomeBasis::Quadratics);
}

// A sky that is quadratic on every face's flat triangle and continuous across edges: Bernstein
// coefficients g(v) at the dome's vertices and h(a, b) on its edges (symmetric, so that the two
// faces of an edge agree along it). The quadratics basis holds it exactly.
Rgb vertex_value(const Vec3& v) { return Rgb(2.0 + v.x() + 0.5 * v.z(), 1.5 - 0.8 * v.y(), 1.0 + 2.0 * v.z()); }
Rgb edge_value(const Vec3& a, const Vec3& b) {
  const Vec3 m = (a + b).normalized();
  return Rgb(2.6 + 1.5 * m.x() * m.y(), 1.2 + m.z() * m.z(), 0.7 + 2.5 * m.z());
}

// The six true coefficients of face i, in geom::layer_values' order.
std::vector<Rgb> true_coefficients(const geom::Dome& d, int face) {
  std::array<Vec3, 3> v;
  for (std::size_t k = 0; k < 3; ++k) v[k] = d.vertices()[static_cast<std::size_t>(d.face(face).vertex[k])];
  return {vertex_value(v[0]),    vertex_value(v[1]),    vertex_value(v[2]),
          edge_value(v[0], v[1]), edge_value(v[1], v[2]), edge_value(v[2], v[0])};
}

Rgb piecewise_quadratic(const geom::Dome& d, const geom::CornerWeights& weights, const Vec3& direction) {
  const int face = d.face_of(direction);
  if (face < 0) return Rgb::Zero();
  const geom::LayerValues phi = geom::layer_values(geom::DomeBasis::Quadratics, weights(face, direction));
  const std::vector<Rgb> c = true_coefficients(d, face);
  Rgb value = Rgb::Zero();
  for (std::size_t k = 0; k < 6; ++k) value += phi[k] * c[k];
  return value;
}

// Linear across each face: what a linear fit reproduces, written in the quadratic functions.
Rgb piecewise_linear(const geom::Dome& d, const geom::CornerWeights& weights, const Vec3& direction) {
  const int face = d.face_of(direction);
  if (face < 0) return Rgb::Zero();
  const std::array<double, 3> l = weights(face, direction);
  Rgb value = Rgb::Zero();
  for (std::size_t k = 0; k < 3; ++k) {
    value += l[k] * vertex_value(d.vertices()[static_cast<std::size_t>(d.face(face).vertex[k])]);
  }
  return value;
}

double relative(const Rgb& a, const Rgb& b) { return (a - b).norm() / b.norm(); }

TEST(QuadraticsTable, StoresTheSixFunctionsMassOfEveryFace) {
  const SkyTable& table = quadratics_table(2, 1);
  const SkyTable& corners = table_of(2, 1, geom::DomeBasis::Corners);
  EXPECT_EQ(table.basis, geom::DomeBasis::Quadratics);
  // The same samples and barycentric coordinates as the corners table.
  ASSERT_EQ(table.weights, corners.weights);
  ASSERT_EQ(table.corner_weights, corners.corner_weights);
  const geom::Dome& d = dome(2);
  const Eigen::Matrix<double, 3, 6> to_corner = geom::quadratic_to_corner();
  for (int i = 0; i < d.face_count(); ++i) {
    const auto f = static_cast<std::size_t>(i);
    ASSERT_EQ(table.corner_mass[f].rows(), 6);
    ASSERT_EQ(table.corner_full_mass[f].cols(), 6);
    // Seen whole: the face's own mass matrix, well conditioned, inverted.
    EXPECT_LT((table.corner_mass[f] - table.corner_full_mass[f]).norm(), 5e-3 * table.corner_full_mass[f].norm()) << i;
    EXPECT_NEAR(table.corner_conditioning[f], 1.0, 0.02) << i;
    EXPECT_LT((table.corner_inverse[f] * table.corner_mass[f] - Eigen::MatrixXd::Identity(6, 6)).norm(), 1e-8) << i;
    // The hats are in the span of the quadratic functions: P M Pᵀ is the corners' mass matrix
    // over the same samples.
    const Eigen::Matrix3d linear = to_corner * table.corner_mass[f] * to_corner.transpose();
    EXPECT_LT((linear - corners.corner_mass[f]).norm(), 1e-12 * corners.corner_mass[f].norm()) << i;
  }
}

TEST(QuadraticsLuminance, AConstantSkyIsTheConstantInEveryFunction) {
  const Rgb sky(0.25, 0.5, 2.0);
  for (int step : {1, 2}) {
    const Luminance l = compute_luminance(quadratics_table(2, step), dome(2),
                                          frame_of(sample_lens(), [&](const Vec3&) { return sky; }), cv::Mat(), cv::Mat());
    EXPECT_EQ(l.basis, geom::DomeBasis::Quadratics);
    EXPECT_EQ(l.corners_from_mean, 0);
    EXPECT_EQ(l.linear_fits, 0);
    for (const FaceLuminance& f : l.faces) {
      ASSERT_EQ(f.coefficients.size(), 6U);
      EXPECT_LT(relative(f.rgb, sky), 1e-6);
      for (const Rgb& c : f.coefficients) EXPECT_LT(relative(c, sky), 1e-4) << "step " << step;
    }
    EXPECT_EQ(layer_radiances(l).size(), 6U * 40U);
  }
}

TEST(QuadraticsLuminance, ASkyQuadraticOnEveryFaceIsReproducedExactly) {
  for (int nu : {2, 4}) {
    const geom::Dome& d = dome(nu);
    const geom::CornerWeights weights(d);
    const cv::Mat frame = frame_of(sample_lens(), [&](const Vec3& w) { return piecewise_quadratic(d, weights, w); });
    const Luminance l = compute_luminance(quadratics_table(nu, 1), d, frame, cv::Mat(), cv::Mat());
    double worst = 0;
    for (int i = 0; i < d.face_count(); ++i) {
      const FaceLuminance& f = l.faces[static_cast<std::size_t>(i)];
      EXPECT_EQ(f.flags, 0u);
      const std::vector<Rgb> truth = true_coefficients(d, i);
      for (std::size_t k = 0; k < 6; ++k) worst = std::max(worst, relative(f.coefficients[k], truth[k]));
    }
    // Float pixels and 16-bit barycentric coordinates; the six functions' fit amplifies their
    // rounding more than the corners' three do.
    EXPECT_LT(worst, 2e-4) << "ν=" << nu;
  }
}

TEST(QuadraticsLuminance, FitASmoothSkyCloserThanTheCorners) {
  // A glow around a direction (not polynomial): the L2 residual of the fit over the frame's
  // samples shrinks from the linear to the quadratic functions.
  const geom::Dome& d = dome(2);
  const geom::CornerWeights weights(d);
  const Vec3 glow = Vec3(0.3, -0.5, 0.8).normalized();
  const auto sky = [&](const Vec3& w) { return Rgb::Constant(std::exp(3.0 * w.dot(glow))); };
  const cv::Mat frame = frame_of(sample_lens(), sky);
  const auto residual = [&](geom::DomeBasis basis) {
    const SkyTable& table = table_of(2, 2, basis);
    const Luminance l = compute_luminance(table, d, frame, cv::Mat(), cv::Mat());
    double error = 0, total = 0;
    for (const PixelRun& run : table.runs) {
      for (std::int32_t k = 0; k < run.count; ++k) {
        const std::optional<Vec3> w = sample_lens().pixel_to_site(Vec2(run.col_begin + k * table.step, run.row));
        if (!w) continue;
        const geom::LayerValues phi = geom::layer_values(basis, weights(run.face, *w));
        const auto& c = l.faces[static_cast<std::size_t>(run.face)].coefficients;
        double fitted = 0;
        for (std::size_t j = 0; j < c.size(); ++j) fitted += phi[j] * c[j].x();
        const double weight = table.weights[run.weight_offset + static_cast<std::uint32_t>(k)];
        error += weight * std::pow(fitted - sky(*w).x(), 2);
        total += weight * std::pow(sky(*w).x(), 2);
      }
    }
    return std::sqrt(error / total);
  };
  const double linear = residual(geom::DomeBasis::Corners);
  const double quadratic = residual(geom::DomeBasis::Quadratics);
  EXPECT_LT(quadratic, 0.5 * linear) << "corners " << linear << ", quadratics " << quadratic;
}

TEST(QuadraticsLuminance, TheSunsExclusionKeepsTheFitExact) {
  const geom::Dome& d = dome(2);
  const geom::CornerWeights weights(d);
  const camera::Lens& lens = sample_lens();
  const cv::Mat frame = frame_of(lens, [&](const Vec3& w) { return piecewise_quadratic(d, weights, w); });
  const int face = 7;
  const std::optional<Vec2> at = lens.site_to_pixel(d.face(face).centre);
  ASSERT_TRUE(at);
  cv::Mat exclude(frame.size(), CV_8UC1, cv::Scalar(0));
  cv::circle(exclude, cv::Point(static_cast<int>(std::lround(at->x())), static_cast<int>(std::lround(at->y()))), 25,
             cv::Scalar(255), -1);
  const Luminance l = compute_luminance(quadratics_table(2, 1), d, frame, cv::Mat(), exclude);
  const FaceLuminance& f = l.faces[face];
  EXPECT_TRUE(f.flags & kFaceSunRemoved);
  EXPECT_FALSE(f.flags & (kFaceCornersFromMean | kFaceFitLinear));
  EXPECT_LT(f.coverage, 0.95);
  const std::vector<Rgb> truth = true_coefficients(d, face);
  for (std::size_t k = 0; k < 6; ++k) EXPECT_LT(relative(f.coefficients[k], truth[k]), 2e-4) << k;
}

TEST(QuadraticsLuminance, FacesSeenOnASliverFallBackToTheLinearFitThenToTheirMean) {
  // A 150° lens: the horizon faces are seen on strips of several widths.
  const camera::CameraCalibration c = lens_testing::equidistant(400, 75.0);
  const camera::Lens lens(c);
  const geom::Dome& d = dome(2);
  const geom::CornerWeights weights(d);
  const SkyTable table = build_sky_table(lens, d, {1, geom::DomeBasis::Quadratics});
  // Linear on every face: the linear fallback is exact too.
  const cv::Mat frame = frame_of(lens, [&](const Vec3& w) { return piecewise_linear(d, weights, w); });
  const Luminance l = compute_luminance(table, d, frame, cv::Mat(), cv::Mat());
  int quadratic = 0, linear = 0, mean = 0;
  for (int i = 0; i < d.face_count(); ++i) {
    const FaceLuminance& f = l.faces[static_cast<std::size_t>(i)];
    ASSERT_EQ(f.coefficients.size(), 6U);
    for (const Rgb& x : f.coefficients) EXPECT_TRUE(x.allFinite());
    if (f.flags & kFaceUnseen) {
      for (const Rgb& x : f.coefficients) EXPECT_EQ(x, f.rgb);
      continue;
    }
    if (f.flags & kFaceCornersFromMean) {
      ++mean;
      for (const Rgb& x : f.coefficients) EXPECT_EQ(x, f.rgb);
      continue;
    }
    (f.flags & kFaceFitLinear ? linear : quadratic)++;
    // Either fit holds a linear sky: vertex values at the vertices, their means on the edges.
    std::array<Rgb, 3> g;
    for (std::size_t k = 0; k < 3; ++k) g[k] = vertex_value(d.vertices()[static_cast<std::size_t>(d.face(i).vertex[k])]);
    const std::array<Rgb, 6> truth{g[0], g[1], g[2], (g[0] + g[1]) / 2, (g[1] + g[2]) / 2, (g[2] + g[0]) / 2};
    for (std::size_t k = 0; k < 6; ++k) EXPECT_LT(relative(f.coefficients[k], truth[k]), 1e-3) << i << " " << k;
  }
  EXPECT_GT(quadratic, 10);
  EXPECT_GT(linear, 0);
  EXPECT_EQ(l.linear_fits, linear);
  EXPECT_EQ(l.corners_from_mean, mean);
  // A threshold of 0 fits six functions on every seen face.
  LuminanceOptions all;
  all.min_corner_conditioning = 0.0;
  const Luminance every = compute_luminance(table, d, frame, cv::Mat(), cv::Mat(), all);
  EXPECT_EQ(every.linear_fits, 0);
  EXPECT_EQ(every.corners_from_mean, 0);
}

TEST(QuadraticsLuminance, BadPixelsAreCountedAsInTheFacesBasisAndNeverPropagate) {
  const geom::Dome& d = dome(2);
  cv::Mat frame = frame_of(sample_lens(), [](const Vec3& w) { return Rgb(1.0, 2.0, 3.0 + w.z()); });
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 40; ++k) {
    frame.at<cv::Vec3f>(300 + k, 400) = cv::Vec3f(nan, 1, 1);
    frame.at<cv::Vec3f>(500, 300 + k) = cv::Vec3f(inf, 2, -inf);
    frame.at<cv::Vec3f>(700, 500 + k) = cv::Vec3f(-1, 1, 1);
  }
  cv::Mat clipped(frame.size(), CV_8UC1, cv::Scalar(0));
  clipped(cv::Rect(600, 600, 30, 30)).setTo(255);
  const Luminance faces = compute_luminance(lens_testing::sample_table(2, 1), d, frame, clipped, cv::Mat());
  const Luminance quadratics = compute_luminance(quadratics_table(2, 1), d, frame, clipped, cv::Mat());
  EXPECT_EQ(quadratics.nan_pixels, 40);
  EXPECT_EQ(quadratics.inf_pixels, 40);
  EXPECT_EQ(quadratics.negative_pixels, 40);
  EXPECT_EQ(quadratics.clipped_pixels, faces.clipped_pixels);
  for (std::size_t i = 0; i < faces.faces.size(); ++i) {
    const FaceLuminance& a = faces.faces[i];
    const FaceLuminance& b = quadratics.faces[i];
    EXPECT_EQ(a.flags, b.flags & ~std::uint32_t{kFaceCornersFromMean | kFaceFitLinear});
    EXPECT_LT(relative(b.rgb, a.rgb), 1e-6);
    for (const Rgb& x : b.coefficients) EXPECT_TRUE(x.allFinite());
  }
}

TEST(QuadraticsLuminance, AQuadraticsTableWithoutItsMatricesIsRefused) {
  SkyTable table = table_of(2, 4, geom::DomeBasis::Corners);
  table.basis = geom::DomeBasis::Quadratics;  // 3×3 matrices where six functions need 6×6
  const cv::Mat frame(1024, 1024, CV_32FC3, cv::Scalar(1, 1, 1));
  try {
    compute_luminance(table, dome(2), frame, cv::Mat(), cv::Mat());
    ADD_FAILURE() << "a quadratics table with 3×3 mass matrices was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("quadratics"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace skylit::sky
