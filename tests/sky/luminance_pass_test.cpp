// The fitted bases' fast pass (corners and quadratics: float lane sums per face, flushed to
// double; AVX2 or portable) against a plain double-precision reference that sums every sample
// from the definitions, over a real sky (an HDR capture seen by the sample camera, sun and
// negative pixels included).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include <Eigen/LU>

#include "../support/lens_test_support.hpp"
#include "skylit/geom/dome_basis.hpp"
#include "skylit/sky/luminance.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/sky_model.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

using lens_testing::dome;
using lens_testing::sample_lens;
using Rgb = Eigen::Vector3d;

// Tolerances, relative to the face's mean radiance. Float sums of at most 128 additions per lane
// (plus one run) of non-negative terms lie within about 128 ε ≈ 8e-6 of the exact sum, and are
// typically far closer (measured: ≤ 2e-7 for the means, ≤ 2e-6 for the corners, which the
// inverse mass matrix amplifies and whose λ2 part is a difference of sums). The quadratics'
// functions come from sums of monomials (λ2² = 1 − 2λ0 − 2λ1 + …, differences of sums) through a
// 6×6 inverse: measured ≤ 3e-5.
constexpr double kMeanTolerance = 2e-6;
constexpr double kCornerTolerance = 2e-5;
constexpr double kQuadraticTolerance = 2e-4;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

Vector6d quadratic_functions(double l0, double l1) {
  const double l2 = 1.0 - l0 - l1;
  return (Vector6d() << l0 * l0, l1 * l1, l2 * l2, 2 * l0 * l1, 2 * l1 * l2, 2 * l2 * l0).finished();
}

// Per face, every sum in double, sample by sample, straight from the definitions.
struct FaceReference {
  double weight = 0, clipped = 0;
  Rgb sum = Rgb::Zero(), corner0 = Rgb::Zero(), corner1 = Rgb::Zero();
  Eigen::Matrix3d excluded_mass = Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 6, 3> quadratic = Eigen::Matrix<double, 6, 3>::Zero();  // Σ w φ_k L
  Matrix6d quadratic_excluded_mass = Matrix6d::Zero();
  bool excluded = false, bad = false;
};

struct Reference {
  std::vector<FaceReference> faces;
  std::int64_t samples = 0, nan = 0, inf = 0, negative = 0, clipped = 0;
};

Reference reference(const SkyTable& table, const cv::Mat& frame, const cv::Mat& clipped, const cv::Mat& exclude) {
  Reference r;
  r.faces.resize(table.face_solid_angle.size());
  for (const PixelRun& run : table.runs) {
    FaceReference& f = r.faces[static_cast<std::size_t>(run.face)];
    for (int k = 0; k < run.count; ++k) {
      ++r.samples;
      const int col = run.col_begin + k * table.step;
      const std::size_t at = run.weight_offset + static_cast<std::size_t>(k);
      const double w = table.weights[at];
      const double l0 = table.corner_weights[2 * at] * kCornerWeightUnit;
      const double l1 = table.corner_weights[2 * at + 1] * kCornerWeightUnit;
      if (!exclude.empty() && exclude.at<std::uint8_t>(run.row, col) != 0) {
        const Eigen::Vector3d l(l0, l1, 1.0 - l0 - l1);
        f.excluded_mass += w * l * l.transpose();
        const Vector6d phi = quadratic_functions(l0, l1);
        f.quadratic_excluded_mass += w * phi * phi.transpose();
        f.excluded = true;
        continue;
      }
      const cv::Vec3f bgr = frame.at<cv::Vec3f>(run.row, col);
      Rgb rgb;
      bool nan = false, inf = false, negative = false;
      for (int c = 0; c < 3; ++c) {
        double v = bgr[2 - c];
        if (std::isnan(v)) {
          nan = true;
          v = 0;
        } else if (std::isinf(v)) {
          inf = true;
          v = 0;
        } else if (v < 0) {
          negative = true;
          v = 0;
        }
        rgb[c] = v;
      }
      r.nan += nan;
      r.inf += inf;
      r.negative += negative;
      f.bad = f.bad || nan || inf || negative;
      f.weight += w;
      f.sum += w * rgb;
      f.corner0 += w * l0 * rgb;
      f.corner1 += w * l1 * rgb;
      f.quadratic += w * quadratic_functions(l0, l1) * rgb.transpose();
      if (!clipped.empty() && clipped.at<std::uint8_t>(run.row, col) != 0) {
        f.clipped += w;
        ++r.clipped;
      }
    }
  }
  return r;
}

// The park capture (a low sun, negative pixels from its lossy compression) seen by the sample
// camera; `clamped`: the same with negatives set to 0, so that every face takes the fast pass.
const cv::Mat& park_frame(bool clamped) {
  static const cv::Mat raw = render_fisheye(
      sample_lens(), read_equirect(std::filesystem::path(SKYLIT_SOURCE_DIR) / "data" / "hdri" / "park.exr"),
      RenderOptions{1, 0});
  static const cv::Mat positive = cv::max(raw, 0.0f);
  return clamped ? positive : raw;
}

// The sun's disc and halo (a disc around the brightest pixel) and the pixels a camera would clip.
struct Masks {
  cv::Mat exclude, clipped;
};
Masks sun_masks(const cv::Mat& frame) {
  cv::Mat luminance;
  cv::transform(frame, luminance, cv::Matx13f(0.0722f, 0.7152f, 0.2126f));
  cv::Point peak;
  cv::minMaxLoc(luminance, nullptr, nullptr, nullptr, &peak);
  Masks m;
  m.exclude = cv::Mat(frame.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      if (std::hypot(x - peak.x, y - peak.y) <= 12.0) m.exclude.at<std::uint8_t>(y, x) = 255;
    }
  }
  m.clipped = luminance > 20.0f;
  return m;
}

const SkyTable& fitted_table(const camera::Lens& lens, int frequency, int step,
                             geom::DomeBasis basis = geom::DomeBasis::Corners) {
  // the tests run on one thread
  static std::map<std::tuple<const camera::Lens*, int, int, geom::DomeBasis>, SkyTable> cache;
  const auto key = std::make_tuple(&lens, frequency, step, basis);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, build_sky_table(lens, dome(frequency), {step, basis})).first;
  return it->second;
}

struct Errors {
  double mean = 0, corner = 0;
  int fitted = 0;  // faces whose corners were compared with a fit
};

// Every seen face of `l` against the reference; the largest relative errors.
Errors compare(const SkyTable& table, const geom::Dome& d, const Reference& r, const Luminance& l,
               const std::string& what) {
  SCOPED_TRACE(what);
  Errors e;
  EXPECT_EQ(l.samples, r.samples);
  EXPECT_EQ(l.nan_pixels, r.nan);
  EXPECT_EQ(l.inf_pixels, r.inf);
  EXPECT_EQ(l.negative_pixels, r.negative);
  EXPECT_EQ(l.clipped_pixels, r.clipped);
  for (std::size_t i = 0; i < l.faces.size(); ++i) {
    const FaceLuminance& face = l.faces[i];
    const FaceReference& f = r.faces[i];
    EXPECT_EQ((face.flags & kFaceSunRemoved) != 0, f.excluded) << i;
    EXPECT_EQ((face.flags & kFaceBadPixels) != 0, f.bad) << i;
    if (face.flags & kFaceUnseen) continue;
    EXPECT_NEAR(face.coverage, f.weight / d.faces()[i].solid_angle, 1e-12 * face.coverage + 1e-15) << i;
    EXPECT_NEAR(face.clipped_fraction, f.clipped / f.weight, 1e-12) << i;
    const Rgb mean = f.sum / f.weight;
    const double scale = std::max(mean.norm(), 1e-30);
    e.mean = std::max(e.mean, (face.rgb - mean).norm() / scale);
    if (face.flags & kFaceCornersFromMean) continue;
    if (table.basis == geom::DomeBasis::Quadratics) {
      if (face.flags & kFaceFitLinear) continue;  // the pixels pin down three functions only
      const Matrix6d mass = Matrix6d(table.corner_mass[i]) - f.quadratic_excluded_mass;
      const Eigen::Matrix<double, 6, 3> fit = mass.inverse() * f.quadratic;
      for (int k = 0; k < 6; ++k) {
        const Rgb expected = fit.row(k).transpose();
        e.corner = std::max(e.corner, (face.coefficients[static_cast<std::size_t>(k)] - expected).norm() / scale);
      }
      ++e.fitted;
      continue;
    }
    const Eigen::Matrix3d mass = table.corner_mass[i] - f.excluded_mass;
    Eigen::Matrix3d b;
    b.row(0) = f.corner0.transpose();
    b.row(1) = f.corner1.transpose();
    b.row(2) = (f.sum - f.corner0 - f.corner1).transpose();
    const Eigen::Matrix3d fit = mass.inverse() * b;
    for (int k = 0; k < 3; ++k) {
      const Rgb expected = fit.row(k).transpose();
      e.corner = std::max(e.corner, (face.coefficients[static_cast<std::size_t>(k)] - expected).norm() / scale);
    }
    ++e.fitted;
  }

  EXPECT_LT(e.mean, kMeanTolerance);
  EXPECT_LT(e.corner, table.basis == geom::DomeBasis::Quadratics ? kQuadraticTolerance : kCornerTolerance);
  return e;
}

struct PassCase {
  int frequency, step;
  bool clamped, masks;
  geom::DomeBasis basis = geom::DomeBasis::Corners;
};

void PrintTo(const PassCase& c, std::ostream* out) {
  *out << geom::basis_name(c.basis) << " ν=" << c.frequency << " step " << c.step << (c.clamped ? " clamped" : " raw") << (c.masks ? " masks" : "");
}

class FittedPassTest : public ::testing::TestWithParam<PassCase> {};

TEST_P(FittedPassTest, MatchesADoubleReferenceOnARealSky) {
  const PassCase c = GetParam();
  const geom::Dome& d = dome(c.frequency);
  const SkyTable& table = fitted_table(sample_lens(), c.frequency, c.step, c.basis);
  const cv::Mat& frame = park_frame(c.clamped);
  const Masks m = c.masks ? sun_masks(frame) : Masks{};
  const Reference r = reference(table, frame, m.clipped, m.exclude);
  if (c.masks) {
    ASSERT_GT(r.clipped, 0);
    ASSERT_TRUE(std::any_of(r.faces.begin(), r.faces.end(), [](const FaceReference& f) { return f.excluded; }));
  }
  // The raw capture has negative pixels on the dome (faces summed again value by value); the
  // clamped one has none (every face from the fast lane sums).
  if (c.clamped) {
    ASSERT_EQ(r.negative, 0);
  } else {
    ASSERT_GT(r.negative, 0);
  }
  for (const bool simd : {true, false}) {
    LuminanceOptions options;
    options.use_simd = simd;
    const Luminance l = compute_luminance(table, d, frame, m.clipped, m.exclude, options);
    const Errors e = compare(table, d, r, l, simd ? "simd" : "portable");
    EXPECT_GT(e.fitted, d.face_count() / 4);
    // The same frame inside a larger image whose other pixels are NaN: the pass reads past a
    // run's end (and zeroes those lanes), and must give the same.
    cv::Mat padded(frame.rows + 2, frame.cols + 8, CV_32FC3, cv::Scalar::all(std::nan("")));
    frame.copyTo(padded(cv::Rect(0, 1, frame.cols, frame.rows)));
    const Luminance p =
        compute_luminance(table, d, padded(cv::Rect(0, 1, frame.cols, frame.rows)), m.clipped, m.exclude, options);
    ASSERT_EQ(p.faces.size(), l.faces.size());
    for (std::size_t i = 0; i < l.faces.size(); ++i) {
      EXPECT_EQ(p.faces[i].rgb, l.faces[i].rgb) << i;
      EXPECT_EQ(p.faces[i].coefficients, l.faces[i].coefficients) << i;
    }
  }
}

constexpr geom::DomeBasis kQuadratics = geom::DomeBasis::Quadratics;
INSTANTIATE_TEST_SUITE_P(Cases, FittedPassTest,
                         ::testing::Values(PassCase{2, 1, true, false}, PassCase{2, 1, false, true},
                                           PassCase{8, 1, true, true}, PassCase{8, 1, false, false},
                                           PassCase{8, 3, true, true}, PassCase{2, 2, false, true},
                                           PassCase{2, 1, true, false, kQuadratics},
                                           PassCase{2, 1, false, true, kQuadratics},
                                           PassCase{8, 1, true, true, kQuadratics},
                                           PassCase{8, 3, false, false, kQuadratics},
                                           PassCase{2, 2, true, true, kQuadratics}),
                         [](const ::testing::TestParamInfo<PassCase>& param_info) {
                           const PassCase& c = param_info.param;
                           return std::string(geom::basis_name(c.basis)) + "_nu" + std::to_string(c.frequency) + "_step" + std::to_string(c.step) +
                                  (c.clamped ? "_clamped" : "_raw") + (c.masks ? "_masks" : "");
                         });

// A lens whose view fills the whole frame: the last run ends at the frame's last pixel, where the
// pass cannot read past it and copies the run's last samples instead.
TEST(FittedPass, RunsThatEndAtTheFramesEnd) {
  const camera::Lens lens(lens_testing::equidistant(203, 60.0));
  const geom::Dome& d = dome(8);
  for (const geom::DomeBasis basis : {geom::DomeBasis::Corners, geom::DomeBasis::Quadratics}) {
    SCOPED_TRACE(std::string(geom::basis_name(basis)));
    const SkyTable& table = fitted_table(lens, 8, 1, basis);
    ASSERT_FALSE(table.runs.empty());
    const PixelRun& last = table.runs.back();
    ASSERT_EQ(last.row, 202);
    ASSERT_EQ(last.col_begin + last.count, 203);
    ASSERT_NE(last.count % 8, 0);  // a group of fewer than eight samples at the very end
    const ClearSky sky(Eigen::Vector3d(0.3, -0.5, 0.8).normalized());
    const cv::Mat frame = render_fisheye(lens, sky_function(sky), RenderOptions{1, 0});
    const Reference r = reference(table, frame, {}, {});
    for (const bool simd : {true, false}) {
      LuminanceOptions options;
      options.use_simd = simd;
      compare(table, d, r, compute_luminance(table, d, frame, {}, {}, options), simd ? "simd" : "portable");
    }
  }
}

}  // namespace
}  // namespace skylit::sky
