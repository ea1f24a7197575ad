// The corners basis in the sky stage: the table's barycentric weights and mass matrices, and the
// per-face least-squares fit of three corner radiances.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <vector>

#include <opencv2/core.hpp>

#include "../support/lens_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

using lens_testing::dome;
using lens_testing::frame_of;
using lens_testing::sample_lens;
using Rgb = Eigen::Vector3d;

const SkyTable& corners_table(int frequency, int step) {
  static std::map<std::pair<int, int>, SkyTable> cache;
  const std::pair<int, int> key(frequency, step);
  auto it = cache.find(key);
  if (it == cache.end()) {
    it = cache.emplace(key, build_sky_table(sample_lens(), dome(frequency), {step, geom::DomeBasis::Corners})).first;
  }
  return it->second;
}

// A sky that is linear on every face's flat triangle and continuous across edges: the values
// g(v) at the dome's vertices, interpolated with the hats. The corners basis holds it exactly.
Rgb vertex_value(const Vec3& v) { return Rgb(2.0 + v.x() + 0.5 * v.z(), 1.5 - 0.8 * v.y(), 1.0 + 2.0 * v.z()); }

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

TEST(CornersTable, StoresBarycentricWeightsAndTheMassOfEveryFace) {
  const SkyTable& table = corners_table(2, 1);
  const SkyTable& faces = lens_testing::sample_table(2, 1);
  EXPECT_EQ(table.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(faces.basis, geom::DomeBasis::Faces);
  EXPECT_TRUE(faces.corner_weights.empty());
  // The same samples as the faces table, with two coordinates each.
  ASSERT_EQ(table.weights, faces.weights);
  ASSERT_EQ(table.corner_weights.size(), 2 * table.weights.size());
  for (std::size_t k = 0; k < table.weights.size(); ++k) {
    ASSERT_LE(table.corner_weights[2 * k] + table.corner_weights[2 * k + 1], 65535);  // λ2 ≥ 0
  }
  // A face the camera sees whole has the mass matrix of the face: ∫ λ λᵀ dω (exactly Ω/6 on the
  // diagonal and Ω/12 off it for a flat triangle; the sphere bends that a little).
  const geom::Dome& d = dome(2);
  int whole = 0;
  for (int i = 0; i < d.face_count(); ++i) {
    const auto f = static_cast<std::size_t>(i);
    if (table.coverage[f] < 0.999) continue;
    ++whole;
    EXPECT_LT((table.corner_mass[f] - table.corner_full_mass[f]).norm(), 3e-3 * table.corner_full_mass[f].norm()) << i;
    EXPECT_NEAR(table.corner_conditioning[f], 1.0, 0.01) << i;
    EXPECT_LT((table.corner_inverse[f] * table.corner_mass[f] - Eigen::Matrix3d::Identity()).norm(), 1e-9);
    const double omega = d.face(i).solid_angle;
    EXPECT_NEAR(table.corner_full_mass[f](0, 0), omega / 6.0, 0.03 * omega / 6.0);
    EXPECT_NEAR(table.corner_full_mass[f](0, 1), omega / 12.0, 0.03 * omega / 12.0);
  }
  EXPECT_EQ(whole, d.face_count());  // the sample camera sees the whole hemisphere
}

TEST(CornersLuminance, AConstantSkyIsTheConstantInEveryCorner) {
  const Rgb sky(0.25, 0.5, 2.0);
  for (int step : {1, 2, 4}) {
    const Luminance l = compute_luminance(corners_table(2, step), dome(2),
                                          frame_of(sample_lens(), [&](const Vec3&) { return sky; }), cv::Mat(), cv::Mat());
    EXPECT_EQ(l.basis, geom::DomeBasis::Corners);
    EXPECT_EQ(l.corners_from_mean, 0);
    for (const FaceLuminance& f : l.faces) {
      EXPECT_LT(relative(f.rgb, sky), 1e-6);
      for (const Rgb& c : f.coefficients) EXPECT_LT(relative(c, sky), 2e-5) << "step " << step;
    }
  }
}

TEST(CornersLuminance, ASkyLinearOnEveryFaceIsReproducedExactly) {
  for (int nu : {2, 4}) {
    const geom::Dome& d = dome(nu);
    const geom::CornerWeights weights(d);
    const cv::Mat frame = frame_of(sample_lens(), [&](const Vec3& w) { return piecewise_linear(d, weights, w); });
    const Luminance l = compute_luminance(corners_table(nu, 1), d, frame, cv::Mat(), cv::Mat());
    double worst = 0;
    for (int i = 0; i < d.face_count(); ++i) {
      const FaceLuminance& f = l.faces[static_cast<std::size_t>(i)];
      EXPECT_EQ(f.flags, 0u);
      for (std::size_t k = 0; k < 3; ++k) {
        const Rgb truth = vertex_value(d.vertices()[static_cast<std::size_t>(d.face(i).vertex[k])]);
        worst = std::max(worst, relative(f.coefficients[k], truth));
      }
    }
    // Float pixels and float sums along a run; the faces basis' mean of the same sky is off by
    // the sky's whole variation across a face (tens of percent).
    EXPECT_LT(worst, 2e-5) << "ν=" << nu;
  }
}

TEST(CornersLuminance, ALinearSkyInTheUnitDirectionIsCloseButNotExact) {
  // L = a + b·ω is not linear on the flat triangles (p = ω/(s·ω) bends): the fit misses the
  // vertex values by a few percent of |b| at ν = 2, less at ν = 4 (dome_basis.hpp).
  for (int nu : {2, 4}) {
    const geom::Dome& d = dome(nu);
    const auto sky = [](const Vec3& w) { return Rgb::Constant(3.0 + w.x() - 0.5 * w.y() + 0.8 * w.z()); };
    const double b = Vec3(1.0, -0.5, 0.8).norm();
    const Luminance l = compute_luminance(corners_table(nu, 1), d, frame_of(sample_lens(), sky), cv::Mat(), cv::Mat());
    double worst = 0;
    for (int i = 0; i < d.face_count(); ++i) {
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3 v = d.vertices()[static_cast<std::size_t>(d.face(i).vertex[k])];
        worst = std::max(worst, std::abs(l.faces[static_cast<std::size_t>(i)].coefficients[k].x() - sky(v).x()) / b);
      }
    }
    EXPECT_GT(worst, 1e-4);
    EXPECT_LT(worst, nu == 2 ? 0.06 : 0.015) << "ν=" << nu;  // measured 0.051, 0.013
  }
}

TEST(CornersLuminance, TheSunsExclusionKeepsTheFitExact) {
  const geom::Dome& d = dome(2);
  const geom::CornerWeights weights(d);
  const camera::Lens& lens = sample_lens();
  const cv::Mat frame = frame_of(lens, [&](const Vec3& w) { return piecewise_linear(d, weights, w); });
  // A disc of 25 pixels' radius around face 7's centre.
  const int face = 7;
  const std::optional<Vec2> at = lens.site_to_pixel(d.face(face).centre);
  ASSERT_TRUE(at);
  cv::Mat exclude(frame.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < exclude.rows; ++y) {
    for (int x = 0; x < exclude.cols; ++x) {
      if (std::hypot(x - at->x(), y - at->y()) <= 25.0) exclude.at<std::uint8_t>(y, x) = 255;
    }
  }
  const Luminance l = compute_luminance(corners_table(2, 1), d, frame, cv::Mat(), exclude);
  const FaceLuminance& f = l.faces[face];
  EXPECT_TRUE(f.flags & kFaceSunRemoved);
  EXPECT_FALSE(f.flags & kFaceCornersFromMean);
  EXPECT_LT(f.coverage, 0.95);
  for (std::size_t k = 0; k < 3; ++k) {
    const Rgb truth = vertex_value(d.vertices()[static_cast<std::size_t>(d.face(face).vertex[k])]);
    EXPECT_LT(relative(f.coefficients[k], truth), 2e-5);
  }
}

TEST(CornersLuminance, FacesSeenOnASliverCarryTheirMeanAndAreFlagged) {
  // A 150° lens: the horizon faces are seen on a strip, those beyond it not at all.
  const camera::CameraCalibration c = lens_testing::equidistant(400, 75.0);
  const camera::Lens lens(c);
  const geom::Dome& d = dome(2);
  const geom::CornerWeights weights(d);
  const SkyTable table = build_sky_table(lens, d, {1, geom::DomeBasis::Corners});
  const cv::Mat frame = frame_of(lens, [&](const Vec3& w) { return piecewise_linear(d, weights, w); });
  const Luminance l = compute_luminance(table, d, frame, cv::Mat(), cv::Mat());
  int sliver = 0, fitted = 0;
  for (int i = 0; i < d.face_count(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const FaceLuminance& f = l.faces[k];
    if (f.flags & kFaceUnseen) {
      for (const Rgb& corner : f.coefficients) EXPECT_EQ(corner, f.rgb);  // filled: all three corners
      EXPECT_GT(f.rgb.minCoeff(), 0.0);
      continue;
    }
    if (table.corner_conditioning[k] < LuminanceOptions{}.min_corner_conditioning) {
      ++sliver;
      EXPECT_TRUE(f.flags & kFaceCornersFromMean) << i;
      for (const Rgb& corner : f.coefficients) EXPECT_EQ(corner, f.rgb);
    } else {
      ++fitted;
      EXPECT_FALSE(f.flags & kFaceCornersFromMean) << i;
      for (std::size_t v = 0; v < 3; ++v) {
        // Partly seen but well conditioned: still exact, the sky being linear on the face.
        EXPECT_LT(relative(f.coefficients[v], vertex_value(d.vertices()[static_cast<std::size_t>(d.face(i).vertex[v])])), 1e-4);
      }
    }
  }
  EXPECT_GT(sliver, 0);
  EXPECT_GT(fitted, 10);
  EXPECT_EQ(l.corners_from_mean, sliver);
  // A threshold of 0 fits every seen face.
  LuminanceOptions all;
  all.min_corner_conditioning = 0.0;
  EXPECT_EQ(compute_luminance(table, d, frame, cv::Mat(), cv::Mat(), all).corners_from_mean, 0);
}

TEST(CornersLuminance, BadPixelsAreCountedAsInTheFacesBasisAndNeverPropagate) {
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
  const Luminance corners = compute_luminance(corners_table(2, 1), d, frame, clipped, cv::Mat());
  EXPECT_EQ(corners.nan_pixels, 40);
  EXPECT_EQ(corners.inf_pixels, 40);
  EXPECT_EQ(corners.negative_pixels, 40);
  EXPECT_EQ(corners.clipped_pixels, faces.clipped_pixels);
  EXPECT_GT(corners.clipped_pixels, 0);
  for (std::size_t i = 0; i < faces.faces.size(); ++i) {
    const FaceLuminance& a = faces.faces[i];
    const FaceLuminance& b = corners.faces[i];
    EXPECT_EQ(a.flags, b.flags & ~std::uint32_t{kFaceCornersFromMean});
    EXPECT_LT(relative(b.rgb, a.rgb), 1e-6);  // the same mean, from float sums along runs
    EXPECT_NEAR(b.clipped_fraction, a.clipped_fraction, 1e-6);
    for (const Rgb& c : b.coefficients) EXPECT_TRUE(c.allFinite());
  }
}

TEST(CornersLuminance, LayerRadiancesFollowTheBakesLayerOrder) {
  Luminance l;
  l.faces.resize(2);
  l.faces[0].rgb = Rgb(1, 1, 1);
  l.faces[1].rgb = Rgb(2, 2, 2);
  l.faces[0].coefficients = {Rgb(1, 0, 0), Rgb(0, 1, 0), Rgb(0, 0, 1)};
  l.faces[1].coefficients = {Rgb(3, 0, 0), Rgb(0, -3, 0), Rgb(0, 0, 3)};
  EXPECT_EQ(layer_radiances(l), (std::vector<Rgb>{Rgb(1, 1, 1), Rgb(2, 2, 2)}));
  l.basis = geom::DomeBasis::Corners;
  EXPECT_EQ(layer_radiances(l), (std::vector<Rgb>{Rgb(1, 0, 0), Rgb(0, 1, 0), Rgb(0, 0, 1), Rgb(3, 0, 0),
                                                  Rgb(0, -3, 0), Rgb(0, 0, 3)}));
}

TEST(CornersLuminance, ACornersTableWithoutItsWeightsIsRefused) {
  SkyTable table = lens_testing::sample_table(2, 4);
  table.basis = geom::DomeBasis::Corners;  // but no barycentric weights nor mass matrices
  const cv::Mat frame(1024, 1024, CV_32FC3, cv::Scalar(1, 1, 1));
  EXPECT_THROW(compute_luminance(table, dome(2), frame, cv::Mat(), cv::Mat()), InputError);
  LuminanceOptions bad;
  bad.min_corner_conditioning = -1.0;
  EXPECT_THROW(compute_luminance(corners_table(2, 4), dome(2), frame, cv::Mat(), cv::Mat(), bad), InputError);
}

}  // namespace
}  // namespace skylit::sky
