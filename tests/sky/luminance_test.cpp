#include "skylit/sky/luminance.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../support/lens_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/geom/spherical.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace luminance_test {  // named, not anonymous: the test program is one unity build

using lens_testing::dome;
using lens_testing::frame_of;
using lens_testing::sample_lens;
using lens_testing::sample_table;
using Rgb = Eigen::Vector3d;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

cv::Mat constant_frame(const Rgb& rgb) {
  return cv::Mat(1024, 1024, CV_32FC3,
                 cv::Scalar(static_cast<float>(rgb.z()), static_cast<float>(rgb.y()),
                            static_cast<float>(rgb.x())));
}

// The plain definition, sample by sample: what compute_luminance must reproduce.
struct Reference {
  std::vector<Rgb> sum;
  std::vector<double> weight, clipped;
  std::vector<bool> bad, excluded;
  std::int64_t nan = 0, inf = 0, negative = 0, clipped_pixels = 0, samples = 0;
};

Reference reference(const SkyTable& table, int faces, const cv::Mat& radiance,
                    const cv::Mat& clipped = {}, const cv::Mat& exclude = {}) {
  const auto n = static_cast<std::size_t>(faces);
  Reference r{std::vector<Rgb>(n, Rgb::Zero()), std::vector<double>(n, 0.0),
              std::vector<double>(n, 0.0), std::vector<bool>(n, false),
              std::vector<bool>(n, false)};
  for (const PixelRun& run : table.runs) {
    const auto f = static_cast<std::size_t>(run.face);
    for (int k = 0; k < run.count; ++k) {
      const int col = run.col_begin + k * table.step;
      const double w = table.weights[run.weight_offset + static_cast<std::uint32_t>(k)];
      r.samples += 1;
      if (!exclude.empty() && exclude.at<std::uint8_t>(run.row, col) != 0) {
        r.excluded[f] = true;
        continue;
      }
      cv::Vec3f p = radiance.at<cv::Vec3f>(run.row, col);
      bool nan = false, inf = false, negative = false;
      for (int ch = 0; ch < 3; ++ch) {
        if (std::isnan(p[ch])) {
          nan = true;
          p[ch] = 0;
        } else if (std::isinf(p[ch])) {
          inf = true;
          p[ch] = 0;
        } else if (p[ch] < 0) {
          negative = true;
          p[ch] = 0;
        }
      }
      r.nan += nan;
      r.inf += inf;
      r.negative += negative;
      if (nan || inf || negative) r.bad[f] = true;
      r.sum[f] += w * Rgb(p[2], p[1], p[0]);
      r.weight[f] += w;
      if (!clipped.empty() && clipped.at<std::uint8_t>(run.row, col) != 0) {
        r.clipped[f] += w;
        ++r.clipped_pixels;
      }
    }
  }
  return r;
}

void expect_no_nan(const Luminance& l) {
  for (const FaceLuminance& face : l.faces) {
    ASSERT_TRUE(face.rgb.allFinite());
    ASSERT_TRUE(std::isfinite(face.coverage));
    ASSERT_TRUE(std::isfinite(face.clipped_fraction));
  }
}

TEST(Luminance, ConstantSkyGivesTheConstant) {
  const Rgb sky(1.0, 0.5, 0.25);
  for (const int step : {1, 2, 4}) {
    SCOPED_TRACE("step " + std::to_string(step));
    const SkyTable& table = sample_table(2, step);
    const Luminance l = compute_luminance(table, dome(2), constant_frame(sky), {}, {});
    ASSERT_EQ(l.faces.size(), 40u);
    for (std::size_t i = 0; i < 40; ++i) {
      EXPECT_NEAR((l.faces[i].rgb - sky).norm(), 0.0, 1e-6) << i;
      EXPECT_NEAR(l.faces[i].coverage, table.coverage[i], 1e-9);
      EXPECT_EQ(l.faces[i].flags, 0u);
      EXPECT_EQ(l.faces[i].clipped_fraction, 0.0);
    }
    EXPECT_EQ(l.samples, static_cast<std::int64_t>(table.sample_count()));
    EXPECT_EQ(l.nan_pixels + l.inf_pixels + l.negative_pixels + l.clipped_pixels, 0);
    EXPECT_EQ(l.unseen_faces, 0);
    EXPECT_FALSE(l.no_face_seen);
  }
}

// L(ω) = a + b·z: the mean over face i is a + b·∫z dω / Ω_i (Lambert's formula for ∫z). The
// error comes from the blocks on face edges (a block goes wholly to one face) and grows with
// the block size.
TEST(Luminance, LinearSkyGivesTheFaceMeans) {
  const Rgb a(0.2, 0.4, 0.1), b(1.5, 0.5, 3.0);
  const cv::Mat frame = frame_of(sample_lens(), [&](const Vec3& d) { return Rgb(a + b * d.z()); });
  std::vector<double> errors;
  for (const int step : {1, 2, 4}) {
    SCOPED_TRACE("step " + std::to_string(step));
    const Luminance l = compute_luminance(sample_table(2, step), dome(2), frame, {}, {});
    double worst = 0;
    for (int i = 0; i < 40; ++i) {
      const geom::DomeFace& face = dome(2).face(i);
      const double mean_z =
          geom::cosine_integral(dome(2).triangle(i), Vec3(0, 0, 1)) / face.solid_angle;
      const Rgb expected = a + b * mean_z;
      const Rgb got = l.faces[static_cast<std::size_t>(i)].rgb;
      worst = std::max(worst, ((got - expected).array() / b.array()).abs().maxCoeff());
    }
    // In units of b (the sky's range): 2.5e-4 per pixel of block side (measured: 1.1e-4, 4.1e-4
    // and 6.1e-4 for steps 1, 2 and 4).
    EXPECT_LT(worst, 2.5e-4 * step);
    errors.push_back(worst);
  }
  EXPECT_LT(errors.front(), errors.back());
}

// Paint every pixel with the colour of the face its centre sees: each face gets its colour back.
TEST(Luminance, OneColourPerFaceComesBack) {
  const auto colour = [](int face) { return Rgb(face + 1.0, 0.5 * face, 100.0 - face); };
  const cv::Mat frame = frame_of(sample_lens(), [&](const Vec3& d) {
    const int face = dome(2).face_of(d);
    return face < 0 ? Rgb(-1, -1, -1) : colour(face);  // below the horizon: never sampled
  });
  const Luminance l = compute_luminance(sample_table(2, 1), dome(2), frame, {}, {});
  for (int i = 0; i < 40; ++i) {
    EXPECT_NEAR((l.faces[static_cast<std::size_t>(i)].rgb - colour(i)).norm(), 0.0, 1e-9) << i;
  }
  EXPECT_EQ(l.negative_pixels, 0);  // the table never reads below the horizon
}

TEST(Luminance, BadPixelsAreCountedAsZeroAndNeverReachS) {
  const SkyTable& table = sample_table(2, 1);
  cv::Mat frame = constant_frame(Rgb(1, 1, 1));
  const auto set = [&](int x, int y, float b, float g, float r) {
    frame.at<cv::Vec3f>(y, x) = cv::Vec3f(b, g, r);
  };
  set(500, 500, kNaN, 1, 1);
  set(510, 500, 1, kInf, 1);
  set(520, 500, 1, 1, -kInf);
  set(530, 500, -0.5f, 1, 1);
  set(540, 500, kNaN, kNaN, 1);      // counts once as NaN
  set(550, 500, kNaN, -1, 2);        // once as NaN, once as negative
  set(200, 800, -1e-3f, -2, -3);     // once as negative
  set(800, 200, kInf, -kInf, kNaN);  // once as Inf, once as NaN
  const Luminance l = compute_luminance(table, dome(2), frame, {}, {});
  EXPECT_EQ(l.nan_pixels, 4);
  EXPECT_EQ(l.inf_pixels, 3);
  EXPECT_EQ(l.negative_pixels, 3);
  expect_no_nan(l);
  const Reference r = reference(table, 40, frame);
  for (std::size_t i = 0; i < 40; ++i) {
    EXPECT_NEAR((l.faces[i].rgb - r.sum[i] / r.weight[i]).norm(), 0.0, 1e-12) << i;
    EXPECT_EQ((l.faces[i].flags & kFaceBadPixels) != 0, r.bad[i]) << i;
    if (r.bad[i]) {
      EXPECT_LT(l.faces[i].rgb.minCoeff(), 1.0);  // the bad channels counted as 0
    } else {
      EXPECT_NEAR((l.faces[i].rgb - Rgb(1, 1, 1)).norm(), 0.0, 1e-6);
    }
  }
  EXPECT_GE(std::count(r.bad.begin(), r.bad.end(), true), 3);  // the faces those pixels lie in
}

TEST(Luminance, ClippedPixelsGiveTheClippedFraction) {
  const SkyTable& table = sample_table(2, 2);
  const cv::Mat frame = constant_frame(Rgb(2, 3, 4));
  cv::Mat clipped(1024, 1024, CV_8UC1, cv::Scalar(0));
  cv::circle(clipped, cv::Point(700, 300), 60, cv::Scalar(255), cv::FILLED);
  const Luminance l = compute_luminance(table, dome(2), frame, clipped, {});
  const Reference r = reference(table, 40, frame, clipped);
  EXPECT_EQ(l.clipped_pixels, r.clipped_pixels);
  EXPECT_GT(l.clipped_pixels, 2000);
  int flagged = 0;
  for (std::size_t i = 0; i < 40; ++i) {
    EXPECT_NEAR(l.faces[i].clipped_fraction, r.clipped[i] / r.weight[i], 1e-12) << i;
    EXPECT_EQ((l.faces[i].flags & kFaceClipped) != 0, r.clipped[i] > 0) << i;
    flagged += r.clipped[i] > 0;
    EXPECT_NEAR((l.faces[i].rgb - Rgb(2, 3, 4)).norm(), 0.0, 1e-6);  // clipped values still count
  }
  EXPECT_GE(flagged, 1);
}

TEST(Luminance, ExcludedPixelsReduceCoverage) {
  const SkyTable& table = sample_table(2, 1);
  cv::Mat frame = constant_frame(Rgb(0.5, 0.25, 0.125));
  cv::Mat exclude(1024, 1024, CV_8UC1, cv::Scalar(0));
  cv::circle(exclude, cv::Point(300, 420), 40, cv::Scalar(255), cv::FILLED);
  cv::Mat clipped(1024, 1024, CV_8UC1, cv::Scalar(0));
  cv::circle(clipped, cv::Point(300, 420), 30, cv::Scalar(255),
             cv::FILLED);                                     // inside the exclusion
  frame.at<cv::Vec3f>(420, 300) = cv::Vec3f(kNaN, kInf, -1);  // likewise
  const Luminance l = compute_luminance(table, dome(2), frame, clipped, exclude);
  const Reference r = reference(table, 40, frame, clipped, exclude);
  EXPECT_EQ(l.nan_pixels + l.inf_pixels + l.negative_pixels, 0);  // excluded pixels are not read
  EXPECT_EQ(l.clipped_pixels, 0);
  int removed = 0;
  for (std::size_t i = 0; i < 40; ++i) {
    const FaceLuminance& face = l.faces[i];
    EXPECT_NEAR(face.coverage, r.weight[i] / dome(2).faces()[i].solid_angle, 1e-12) << i;
    EXPECT_EQ((face.flags & kFaceSunRemoved) != 0, r.excluded[i]) << i;
    if (r.excluded[i]) {
      ++removed;
      EXPECT_LT(face.coverage, table.coverage[i] - 1e-3) << i;
    } else {
      EXPECT_DOUBLE_EQ(face.coverage, table.coverage[i]) << i;
    }
    EXPECT_NEAR((face.rgb - Rgb(0.5, 0.25, 0.125)).norm(), 0.0, 1e-6) << i;
  }
  EXPECT_GE(removed, 1);
}

// A 160° lens with a circular image: on a ν=4 dome the lowest horizon faces are seen at 10-15 %
// and, with min_coverage 0.2, are filled from their neighbours.
TEST(Luminance, UnseenFacesAreFilledFromNeighbours) {
  const camera::CameraCalibration c = lens_testing::equidistant(1024, 80);
  const camera::Lens lens(c);
  const SkyTable table = build_sky_table(lens, dome(4), lens_testing::disc_mask(c, 512.0), {2});
  const Rgb a(0.3, 0.6, 1.2), b(2.0, 1.0, 0.5);
  const cv::Mat frame = frame_of(lens, [&](const Vec3& d) {
    return Rgb(a + b * d.z() + Rgb(0.1, 0.2, 0.3) * d.x());  // varies along the horizon too
  });
  LuminanceOptions options;
  options.min_coverage = 0.2;
  const Luminance l = compute_luminance(table, dome(4), frame, {}, {}, options);
  expect_no_nan(l);
  EXPECT_FALSE(l.no_face_seen);
  int unseen = 0, first_wave = 0;
  for (int i = 0; i < 160; ++i) {
    const FaceLuminance& face = l.faces[static_cast<std::size_t>(i)];
    const bool expected_unseen = table.coverage[static_cast<std::size_t>(i)] < 0.2;
    ASSERT_EQ((face.flags & kFaceUnseen) != 0, expected_unseen) << i;
    if (!expected_unseen) continue;
    ++unseen;
    Rgb low = Rgb::Constant(1e300), high = Rgb::Constant(-1e300);
    Rgb weighted = Rgb::Zero();
    double total = 0;
    bool all_neighbours_seen = true;
    for (const int j : dome(4).face(i).neighbour) {
      if (j < 0) continue;
      const FaceLuminance& other = l.faces[static_cast<std::size_t>(j)];
      low = low.cwiseMin(other.rgb);
      high = high.cwiseMax(other.rgb);
      if (other.flags & kFaceUnseen) {
        all_neighbours_seen = false;
      } else {
        weighted += other.coverage * other.rgb;
        total += other.coverage;
      }
    }
    EXPECT_TRUE((face.rgb.array() >= low.array() - 1e-12).all()) << i;
    EXPECT_TRUE((face.rgb.array() <= high.array() + 1e-12).all()) << i;
    if (all_neighbours_seen) {  // filled in the first wave: the coverage-weighted mean
      ++first_wave;
      EXPECT_NEAR((face.rgb - weighted / total).norm(), 0.0, 1e-12) << i;
    }
  }
  EXPECT_EQ(l.unseen_faces, unseen);
  EXPECT_EQ(unseen, 20);
  EXPECT_GT(first_wave, 0);
}

TEST(Luminance, BlackSkyGivesZeros) {
  const Luminance l =
      compute_luminance(sample_table(2, 4), dome(2), constant_frame(Rgb::Zero()), {}, {});
  expect_no_nan(l);
  for (const FaceLuminance& face : l.faces) EXPECT_EQ(face.rgb, Rgb::Zero());
  EXPECT_EQ(l.unseen_faces, 0);
  EXPECT_FALSE(l.no_face_seen);
}

TEST(Luminance, NothingSeenGivesZerosAndSaysSo) {
  const cv::Mat hidden(1024, 1024, CV_8UC1, cv::Scalar(0));
  const SkyTable table = build_sky_table(sample_lens(), dome(2), hidden, {8});
  EXPECT_EQ(table.sample_count(), 0u);
  const Luminance l = compute_luminance(table, dome(2), constant_frame(Rgb(1, 2, 3)), {}, {});
  EXPECT_TRUE(l.no_face_seen);
  EXPECT_EQ(l.unseen_faces, 40);
  expect_no_nan(l);
  for (const FaceLuminance& face : l.faces) {
    EXPECT_EQ(face.rgb, Rgb::Zero());
    EXPECT_NE(face.flags & kFaceUnseen, 0u);
  }
}

// With min_coverage 0 a face no pixel sees is still unseen (it has no mean) and still filled.
TEST(Luminance, ZeroThresholdStillFillsFacesWithoutPixels) {
  cv::Mat mask(1024, 1024, CV_8UC1, cv::Scalar(255));
  mask.colRange(0, 512).setTo(0);
  const SkyTable table = build_sky_table(sample_lens(), dome(2), mask, {4});
  LuminanceOptions options;
  options.min_coverage = 0.0;
  const Luminance l =
      compute_luminance(table, dome(2), constant_frame(Rgb(1, 2, 3)), {}, {}, options);
  expect_no_nan(l);
  EXPECT_GT(l.unseen_faces, 5);
  for (const FaceLuminance& face : l.faces)
    EXPECT_NEAR((face.rgb - Rgb(1, 2, 3)).norm(), 0.0, 1e-6);
}

TEST(Luminance, MismatchedInputsAreInputErrors) {
  const SkyTable& table = sample_table(2, 4);
  const cv::Mat frame = constant_frame(Rgb(1, 1, 1));
  const cv::Mat mask(1024, 1024, CV_8UC1, cv::Scalar(0));
  const auto expect_error = [](const std::function<void()>& call, const std::string& field) {
    try {
      call();
      ADD_FAILURE() << "no error for " << field;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("field '" + field + "'"), std::string::npos) << message;
      EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    }
  };
  expect_error([&] { compute_luminance(table, dome(2), cv::Mat(1024, 1024, CV_8UC3), {}, {}); },
               "radiance");
  expect_error([&] { compute_luminance(table, dome(2), cv::Mat(1024, 512, CV_32FC3), {}, {}); },
               "radiance");
  expect_error([&] { compute_luminance(table, dome(2), cv::Mat(), {}, {}); }, "radiance");
  expect_error([&] { compute_luminance(table, dome(2), frame, cv::Mat(1024, 1024, CV_32FC1), {}); },
               "clipped");
  expect_error([&] { compute_luminance(table, dome(2), frame, {}, cv::Mat(10, 10, CV_8UC1)); },
               "exclude");
  expect_error([&] { compute_luminance(table, dome(4), frame, mask, mask); }, "table");
  LuminanceOptions bad;
  bad.min_coverage = 1.5;
  expect_error([&] { compute_luminance(table, dome(2), frame, {}, {}, bad); }, "min_coverage");
  bad.min_coverage = std::nan("");
  expect_error([&] { compute_luminance(table, dome(2), frame, {}, {}, bad); }, "min_coverage");
  // A table that does not fit the frame is refused, not read out of bounds.
  SkyTable broken = table;
  broken.runs.back().count += 1000;
  expect_error([&] { compute_luminance(broken, dome(2), frame, {}, {}); }, "table");
  broken = table;
  broken.runs.front().weight_offset = static_cast<std::uint32_t>(broken.weights.size());
  expect_error([&] { compute_luminance(broken, dome(2), frame, {}, {}); }, "table");
  broken = table;
  broken.runs.front().face = 40;
  expect_error([&] { compute_luminance(broken, dome(2), frame, {}, {}); }, "table");
}

}  // namespace
}  // namespace skylit::sky
