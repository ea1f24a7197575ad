#include "skylit/sky/sky_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../support/lens_test_support.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/camera/lens.hpp"

namespace skylit::sky {
namespace {

namespace fs = std::filesystem;
using lens_testing::dome;
using lens_testing::sample_lens;
using lens_testing::sample_table;

constexpr double kPi = std::numbers::pi;

double total_weight(const SkyTable& table) {
  double sum = 0;
  for (const float w : table.weights) sum += w;
  return sum;
}

double face_sum(const SkyTable& table) {
  double sum = 0;
  for (const double w : table.face_solid_angle) sum += w;
  return sum;
}

double max_coverage_error(const SkyTable& table) {
  double worst = 0;
  for (const double c : table.coverage) worst = std::max(worst, std::abs(c - 1.0));
  return worst;
}

// Faces with two vertices on the horizon (an edge along it), and faces with the zenith as a vertex.
std::vector<int> faces_on_horizon(const geom::Dome& d) {
  std::vector<int> faces;
  for (int i = 0; i < d.face_count(); ++i) {
    int low = 0;
    for (const int v : d.face(i).vertex)
      low += std::abs(d.vertices()[static_cast<std::size_t>(v)].z()) < 1e-9;
    if (low == 2) faces.push_back(i);
  }
  return faces;
}
std::vector<int> faces_at_zenith(const geom::Dome& d) {
  std::vector<int> faces;
  for (int i = 0; i < d.face_count(); ++i) {
    for (const int v : d.face(i).vertex) {
      if (d.vertices()[static_cast<std::size_t>(v)].z() > 1 - 1e-12) faces.push_back(i);
    }
  }
  return faces;
}

// The sample camera (equidistant, 180° circle just inside 1024²) sees the whole hemisphere: the
// weights add up to 2π and every face is covered once.
TEST(SkyTable, SampleCameraSeesTheWholeHemisphere) {
  const SkyTable& table = sample_table(2, 1);
  EXPECT_EQ(table.image_width, 1024);
  EXPECT_EQ(table.image_height, 1024);
  EXPECT_EQ(table.step, 1);
  ASSERT_EQ(table.face_solid_angle.size(), 40u);
  ASSERT_EQ(table.coverage.size(), 40u);
  EXPECT_NEAR(total_weight(table) / (2 * kPi), 1.0, 1e-3);
  EXPECT_NEAR(face_sum(table), total_weight(table), 1e-9);
  EXPECT_LT(max_coverage_error(table), 2e-3);
  for (int i = 0; i < 40; ++i) {
    EXPECT_DOUBLE_EQ(
        table.coverage[static_cast<std::size_t>(i)],
        table.face_solid_angle[static_cast<std::size_t>(i)] / dome(2).face(i).solid_angle);
  }
  // About π/4 of the image's pixels lie inside the image circle.
  EXPECT_NEAR(static_cast<double>(table.sample_count()) / (1024.0 * 1024.0), kPi / 4, 2e-3);
}

// Coarser sampling keeps the sums: each sample carries its whole block. Coverage per face gets
// coarser with the block: a block goes wholly to the face its centre sees, and on this perfectly
// centred lens the face edges along the image's axes lie half a pixel off the even-step block
// edges all along their length.
TEST(SkyTable, CoarserStepsKeepTheSums) {
  for (const int step : {2, 4}) {
    SCOPED_TRACE("step " + std::to_string(step));
    const SkyTable& table = sample_table(2, step);
    EXPECT_EQ(table.step, step);
    EXPECT_NEAR(total_weight(table) / (2 * kPi), 1.0, 1e-3);
    EXPECT_LT(max_coverage_error(table), 8e-3);
    EXPECT_NEAR(static_cast<double>(table.sample_count()) * step * step / (1024.0 * 1024.0),
                kPi / 4, 5e-3 * step);
  }
}

TEST(SkyTable, FinerDomeIsCoveredToo) {
  const SkyTable& table = sample_table(4, 1);
  ASSERT_EQ(table.coverage.size(), 160u);
  EXPECT_NEAR(total_weight(table) / (2 * kPi), 1.0, 1e-3);
  // Smaller faces: the pixels on a face edge weigh more (and on this perfectly centred lens
  // some edges run through rows of pixel centres, which all go to one side).
  EXPECT_LT(max_coverage_error(table), 1e-2);
}

// Every run is what it claims: the sampled pixel of each block, the face that pixel sees, the
// block's solid angle; runs are maximal and in row-major order.
TEST(SkyTable, RunsDescribeTheSampledBlocks) {
  const camera::Lens& lens = sample_lens();
  for (const int step : {1, 4}) {
    SCOPED_TRACE("step " + std::to_string(step));
    const SkyTable& table = sample_table(2, step);
    std::uint32_t offset = 0;
    const PixelRun* previous = nullptr;
    int checked = 0;
    for (std::size_t r = 0; r < table.runs.size(); ++r) {
      const PixelRun& run = table.runs[r];
      ASSERT_EQ(run.weight_offset, offset);
      ASSERT_GT(run.count, 0);
      ASSERT_GE(run.row, 0);
      ASSERT_LT(run.row, 1024);
      ASSERT_EQ(run.row % step, step / 2);
      ASSERT_EQ(run.col_begin % step, step / 2);
      ASSERT_LT(run.col_begin + (run.count - 1) * step, 1024);
      if (previous) {
        ASSERT_TRUE(run.row > previous->row ||
                    (run.row == previous->row && run.col_begin > previous->col_begin));
        const bool adjacent = run.row == previous->row &&
                              run.col_begin == previous->col_begin + previous->count * step;
        ASSERT_FALSE(adjacent && run.face == previous->face) << "run " << r << " is not maximal";
      }
      previous = &run;
      offset += static_cast<std::uint32_t>(run.count);
      if (step == 1 && r % 23 != 0) continue;  // every sample of step 4, a sample of step 1
      for (int k = 0; k < run.count; ++k) {
        const int col = run.col_begin + k * step;
        // Blocks reach halfway to the next sample, the first and last to the image's edge.
        const auto low = [&](int at) { return at == step / 2 ? -0.5 : at - step / 2.0; };
        const auto high = [&](int at) { return at + step > 1023 ? 1023.5 : at + step / 2.0; };
        const std::optional<Vec3> direction = lens.pixel_to_site(Vec2(col, run.row));
        ASSERT_TRUE(direction.has_value());
        EXPECT_EQ(run.face, dome(2).face_of(*direction)) << "pixel " << col << ", " << run.row;
        EXPECT_EQ(table.weights[run.weight_offset + static_cast<std::uint32_t>(k)],
                  static_cast<float>(
                      block_solid_angle(lens, low(col), low(run.row), high(col), high(run.row))));
        ++checked;
      }
    }
    EXPECT_EQ(offset, table.weights.size());
    EXPECT_GT(checked, 1000);
  }
}

TEST(SkyTable, BlockSolidAngle) {
  const camera::Lens& lens = sample_lens();
  const double fx = lens.calibration().fx;
  // At the optical axis one pixel subtends 1/fx² steradians.
  EXPECT_NEAR(block_solid_angle(lens, 511.0, 511.0, 512.0, 512.0) * fx * fx, 1.0, 1e-5);
  // Corner order does not matter.
  EXPECT_NEAR(
      block_solid_angle(lens, 100, 200, 104, 203) / block_solid_angle(lens, 104, 203, 100, 200),
      1.0, 1e-12);
  // Nearly additive: an 8×8 block against its 64 pixels. Neighbouring blocks share their edges'
  // great arcs, so the two differ only along the outer boundary, which the pieces follow more
  // closely (the image's straight edges are curves on the sphere).
  double pieces = 0;
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x)
      pieces += block_solid_angle(lens, 300 + x, 700 + y, 301 + x, 701 + y);
  }
  EXPECT_NEAR(pieces / block_solid_angle(lens, 300, 700, 308, 708), 1.0, 1e-4);
  // A corner the model cannot unproject: 0.
  camera::CameraCalibration turning = lens_testing::equidistant(1024, 90);
  turning.D = {-0.1, 0, 0, 0};  // stops increasing at θ ≈ 1.83 (θ_d ≈ 1.22)
  const camera::Lens short_lens(turning);
  EXPECT_EQ(block_solid_angle(short_lens, -0.5, -0.5, 0.5, 0.5), 0.0);
  EXPECT_GT(block_solid_angle(short_lens, 511, 511, 512, 512), 0.0);
}

// A 160° lens (image edge 80° from the zenith, a circular image): horizon faces are only partly
// seen, zenith faces wholly.
TEST(SkyTable, NarrowerLensLeavesHorizonFacesPartlySeen) {
  const camera::CameraCalibration c = lens_testing::equidistant(1024, 80);
  const camera::Lens lens(c);
  const cv::Mat circle = lens_testing::disc_mask(c, 512.0);
  const SkyTable table = build_sky_table(lens, dome(2), circle, {1});
  const double cap = 2 * kPi * (1 - std::cos(80.0 * kPi / 180));
  EXPECT_NEAR(total_weight(table) / cap, 1.0, 1e-3);
  const std::vector<int> horizon = faces_on_horizon(dome(2));
  const std::vector<int> zenith = faces_at_zenith(dome(2));
  ASSERT_EQ(horizon.size(), 10u);
  ASSERT_EQ(zenith.size(), 5u);
  for (const int f : horizon) {
    EXPECT_LT(table.coverage[static_cast<std::size_t>(f)], 0.75) << f;
  }
  for (const int f : zenith) {
    EXPECT_NEAR(table.coverage[static_cast<std::size_t>(f)], 1.0, 2e-3) << f;
  }
}

TEST(SkyTable, MaskHidingHalfTheImageHalvesTheTotal) {
  cv::Mat mask(1024, 1024, CV_8UC1, cv::Scalar(255));
  mask.colRange(0, 512).setTo(0);  // the left half: west (camera x is east)
  const SkyTable table = build_sky_table(sample_lens(), dome(2), mask, {1});
  EXPECT_NEAR(total_weight(table) / kPi, 1.0, 1e-3);
  for (const PixelRun& run : table.runs) ASSERT_GE(run.col_begin, 512);
  for (int i = 0; i < 40; ++i) {
    const geom::DomeFace& face = dome(2).face(i);
    double min_x = 1, max_x = -1;
    for (const int v : face.vertex) {
      min_x = std::min(min_x, dome(2).vertices()[static_cast<std::size_t>(v)].x());
      max_x = std::max(max_x, dome(2).vertices()[static_cast<std::size_t>(v)].x());
    }
    const double coverage = table.coverage[static_cast<std::size_t>(i)];
    if (min_x > 1e-9) {
      EXPECT_NEAR(coverage, 1.0, 2e-3) << i;  // wholly east
    }
    if (max_x < -1e-9) {
      EXPECT_EQ(coverage, 0.0) << i;  // wholly west
    }
  }
}

TEST(SkyTable, ReadsTheCalibrationsMaskFile) {
  skylit::test::TempDir dir;
  camera::CameraCalibration c = sample_lens().calibration();
  cv::Mat mask(1024, 1024, CV_8UC1, cv::Scalar(255));
  mask.rowRange(0, 300).setTo(0);
  ASSERT_TRUE(cv::imwrite((dir.path() / "mask.png").string(), mask));
  c.file = dir.path() / "camera.yaml";
  c.mask = dir.path() / "mask.png";
  const SkyTable from_file = build_sky_table(camera::Lens(c), dome(2), {4});
  const SkyTable given = build_sky_table(sample_lens(), dome(2), mask, {4});
  EXPECT_EQ(from_file.weights, given.weights);
  EXPECT_LT(total_weight(from_file), 0.9 * total_weight(sample_table(2, 4)));

  // A mask passed in wins over the file.
  const cv::Mat open(1024, 1024, CV_8UC1, cv::Scalar(255));
  EXPECT_EQ(build_sky_table(camera::Lens(c), dome(2), open, {4}).weights, sample_table(2, 4).weights);

  const auto expect_error = [&](const camera::CameraCalibration& calibration, const std::string& part) {
    try {
      build_sky_table(camera::Lens(calibration), dome(2), {4});
      ADD_FAILURE() << "no error for " << part;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("camera.yaml: field 'mask'"), std::string::npos) << message;
      EXPECT_NE(message.find(part), std::string::npos) << message;
      EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    }
  };
  camera::CameraCalibration missing = c;
  missing.mask = dir.path() / "nowhere.png";
  expect_error(missing, "does not exist");
  camera::CameraCalibration garbage = c;
  garbage.mask = dir.write("garbage.png", "not a png");
  expect_error(garbage, "cannot read the mask image");
  camera::CameraCalibration small = c;
  small.mask = dir.path() / "small.png";
  ASSERT_TRUE(cv::imwrite(small.mask.string(), cv::Mat(100, 200, CV_8UC1, cv::Scalar(255))));
  expect_error(small, "is 200×100 pixels");
}

TEST(SkyTable, BadMaskOrStepIsAnInputError) {
  EXPECT_THROW(build_sky_table(sample_lens(), dome(2), cv::Mat(1024, 1024, CV_8UC3), {4}),
               InputError);
  EXPECT_THROW(build_sky_table(sample_lens(), dome(2), cv::Mat(512, 1024, CV_8UC1), {4}),
               InputError);
  EXPECT_THROW(build_sky_table(sample_lens(), dome(2), cv::Mat(1024, 1024, CV_32FC1), {4}),
               InputError);
  EXPECT_THROW(build_sky_table(sample_lens(), dome(2), {0}), InputError);
  EXPECT_THROW(build_sky_table(sample_lens(), dome(2), {-3}), InputError);
}

// Tilting the camera 30° towards south: through its 180° image circle it sees the lune between
// its own hemisphere and the sky's, 2·(π − 30°) steradians; northern horizon faces drop out,
// southern ones stay whole. (Without the circle's mask the equidistant model would go on past
// 90° in the image's corners, beyond what a real 180° lens sees.)
TEST(SkyTable, TiltedCameraMovesCoverage) {
  camera::CameraCalibration c = sample_lens().calibration();
  c.R_site_from_camera = lens_testing::tilt_about_east(30);
  const camera::Lens lens(c);
  const cv::Mat circle = lens_testing::disc_mask(c, c.fx * kPi / 2);
  const SkyTable table = build_sky_table(lens, dome(2), circle, {2});
  EXPECT_NEAR(total_weight(table) / (2 * (kPi - kPi / 6)), 1.0, 1e-3);
  const Vec3 axis = c.R_site_from_camera * Vec3(0, 0, 1);
  EXPECT_LT(axis.y(), 0);  // towards south
  int whole = 0, lost = 0;
  for (int i = 0; i < 40; ++i) {
    double lowest = 1, highest = -1;  // cosine of the angle from the optical axis
    for (const int v : dome(2).face(i).vertex) {
      const double cosine = dome(2).vertices()[static_cast<std::size_t>(v)].dot(axis);
      lowest = std::min(lowest, cosine);
      highest = std::max(highest, cosine);
    }
    const double coverage = table.coverage[static_cast<std::size_t>(i)];
    if (lowest > 0.02) {
      EXPECT_NEAR(coverage, 1.0, 5e-3) << i;
      ++whole;
    }
    if (highest < -0.02) {
      EXPECT_EQ(coverage, 0.0) << i;
      ++lost;
    }
  }
  EXPECT_GT(whole, 20);
  EXPECT_GT(lost, 0);
  // The sample camera sees every face; the tilted one does not.
  EXPECT_GT(max_coverage_error(table), 0.5);
}

}  // namespace
}  // namespace skylit::sky
