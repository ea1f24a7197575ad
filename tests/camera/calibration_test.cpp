#include "skylit/camera/lens.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "../support/lens_test_support.hpp"
#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::camera {
namespace {

namespace fs = std::filesystem;
using skylit::test::TempDir;

constexpr double kPi = std::numbers::pi;

// A valid calibration; the bad cases below change one line of it.
const std::vector<std::string> kGoodLines = {
    "image_width: 1280",                                 // 1
    "image_height: 960",                                 // 2
    "model: fisheye",                                    // 3
    "fx: 400.25",                                        // 4
    "fy: 401.5",                                         // 5
    "cx: 639.5",                                         // 6
    "cy: 479.25",                                        // 7
    "D: [0.01, -0.002, 0.0003, -0.00004]",               // 8
    "R_site_from_camera: [0, 1, 0, 1, 0, 0, 0, 0, -1]",  // 9
    "t_site_from_camera: [1.5, -2, 3.25]",               // 10
    "mask: masks/sky mask.png",                          // 11
    "rms: 0.21",                                         // 12
    "per_view_errors: [0.1, 0.2, 0.3]",                  // 13
};

std::string join(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// The good calibration with line `line` (1-based) replaced; an empty replacement removes it.
std::string good_with(int line, const std::string& replacement) {
  std::vector<std::string> lines = kGoodLines;
  if (replacement.empty()) {
    lines.erase(lines.begin() + (line - 1));
  } else {
    lines[static_cast<std::size_t>(line - 1)] = replacement;
  }
  return join(lines);
}

// The InputError message of loading `text`, or a failure when it loads.
std::string load_error(const std::string& text, const std::string& name = "camera.yaml") {
  TempDir dir;
  const fs::path file = dir.write(name, text);
  try {
    load_calibration(file);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "loaded without error:\n" << text;
  return {};
}

void expect_same(const CameraCalibration& a, const CameraCalibration& b) {
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
  EXPECT_EQ(a.D, b.D);
  EXPECT_EQ(a.R_site_from_camera, b.R_site_from_camera);
  EXPECT_EQ(a.t_site_from_camera, b.t_site_from_camera);
  EXPECT_EQ(a.mask, b.mask);
  EXPECT_EQ(a.rms, b.rms);
  EXPECT_EQ(a.per_view_errors, b.per_view_errors);
}

TEST(LoadCalibration, ParsesEveryField) {
  TempDir dir;
  const fs::path file = dir.write("cams/sky.yaml", join(kGoodLines));
  const CameraCalibration c = load_calibration(file);
  EXPECT_EQ(c.file, file);
  EXPECT_EQ(c.image_width, 1280);
  EXPECT_EQ(c.image_height, 960);
  EXPECT_EQ(c.model, LensModel::Fisheye);
  EXPECT_EQ(c.fx, 400.25);
  EXPECT_EQ(c.fy, 401.5);
  EXPECT_EQ(c.cx, 639.5);
  EXPECT_EQ(c.cy, 479.25);
  EXPECT_EQ(c.D, (std::vector<double>{0.01, -0.002, 0.0003, -0.00004}));
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  EXPECT_EQ(c.R_site_from_camera, R);
  EXPECT_EQ(c.t_site_from_camera, Vec3(1.5, -2, 3.25));
  EXPECT_EQ(c.mask,
            dir.path() / "cams" / "masks" / "sky mask.png");  // against the YAML's directory
  ASSERT_TRUE(c.rms.has_value());
  EXPECT_EQ(*c.rms, 0.21);
  EXPECT_EQ(c.per_view_errors, (std::vector<double>{0.1, 0.2, 0.3}));
}

TEST(LoadCalibration, OptionalFieldsMayBeLeftOut) {
  TempDir dir;
  std::vector<std::string> lines(kGoodLines.begin(), kGoodLines.begin() + 9);
  const CameraCalibration c = load_calibration(dir.write("sky.yaml", join(lines)));
  EXPECT_EQ(c.t_site_from_camera, Vec3::Zero());
  EXPECT_TRUE(c.mask.empty());
  EXPECT_FALSE(c.rms.has_value());
  EXPECT_TRUE(c.per_view_errors.empty());
}

TEST(LoadCalibration, RotationAsThreeRowsAndAbsoluteMask) {
  TempDir dir;
  std::vector<std::string> lines = kGoodLines;
  lines[8] = "R_site_from_camera: [[0, 1, 0], [1, 0, 0], [0, 0, -1]]";
  lines[10] = "mask: /data/masks/m.png";
  const CameraCalibration c = load_calibration(dir.write("sky.yaml", join(lines)));
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  EXPECT_EQ(c.R_site_from_camera, R);
  EXPECT_EQ(c.mask, fs::path("/data/masks/m.png"));
}

TEST(LoadCalibration, PinholeCoefficientsFourFiveOrEight) {
  TempDir dir;
  std::vector<std::string> lines = kGoodLines;
  lines[2] = "model: pinhole";
  lines[7] = "D: [0.1, -0.02, 0.001, 0.002]";
  CameraCalibration c = load_calibration(dir.write("four.yaml", join(lines)));
  EXPECT_EQ(c.model, LensModel::Pinhole);
  EXPECT_EQ(c.D, (std::vector<double>{0.1, -0.02, 0.001, 0.002, 0.0}));  // missing k3 is 0
  lines[7] = "D: [0.1, -0.02, 0.001, 0.002, 0.003]";
  c = load_calibration(dir.write("five.yaml", join(lines)));
  EXPECT_EQ(c.D.size(), 5u);
  lines[7] = "D: [0.1, -0.02, 0.001, 0.002, 0.003, 0.01, 0.002, 0.0003]";
  c = load_calibration(dir.write("eight.yaml", join(lines)));
  EXPECT_EQ(c.D.size(), 8u);
}

TEST(LoadCalibration, SampleConfigIsTheIdealZenithFisheye) {
  const CameraCalibration c = load_calibration(sky::lens_testing::sample_calibration_file());
  EXPECT_EQ(c.image_width, 1024);
  EXPECT_EQ(c.image_height, 1024);
  EXPECT_EQ(c.model, LensModel::Fisheye);
  EXPECT_EQ(c.D, (std::vector<double>{0, 0, 0, 0}));
  EXPECT_EQ(c.R_site_from_camera, Eigen::Matrix3d::Identity());
  // The 180° image circle lies just inside the image (pixel edges at -0.5 and 1023.5).
  const double radius = c.fx * kPi / 2;
  EXPECT_GT(c.cx - radius, -0.5);
  EXPECT_LT(c.cx + radius, 1023.5);
  EXPECT_GT(radius, 511.0);
}

struct BadCase {
  std::string name;
  std::string text;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(LoadCalibration, EveryBadInputNamesLineFieldAndFix) {
  std::vector<std::string> duplicated = kGoodLines;
  duplicated.push_back("fx: 1");
  std::vector<std::string> pinhole = kGoodLines;
  pinhole[2] = "model: pinhole";
  pinhole[7] = "D: [0, 0, 0, 0, 0, 0]";
  const std::string six_pinhole_coefficients = join(pinhole);
  const std::vector<BadCase> cases = {
      {"typo",
       good_with(1, "image_widht: 1280"),
       {":1:1: field 'image_widht': unknown field", "did you mean 'image_width'?"}},
      {"unknown",
       good_with(12, "colour: red"),
       {":12:1: field 'colour'", "Fix: remove it (allowed:"}},
      {"duplicate", join(duplicated), {":14:1: field 'fx': the field appears twice"}},
      {"missing width",
       good_with(1, ""),
       {"field 'image_width': required field is missing", "Fix: add it"}},
      {"missing model", good_with(3, ""), {"field 'model': required field is missing", "pinhole"}},
      {"missing fx", good_with(4, ""), {"field 'fx': required field is missing"}},
      {"missing cy", good_with(7, ""), {"field 'cy': required field is missing"}},
      {"missing D", good_with(8, ""), {"field 'D': required field is missing"}},
      {"missing R", good_with(9, ""), {"field 'R_site_from_camera': required field is missing"}},
      {"fractional width",
       good_with(1, "image_width: 1280.5"),
       {":1:14: field 'image_width': expected an integer, got '1280.5'"}},
      {"zero width", good_with(1, "image_width: 0"), {"field 'image_width'", "outside 1..32768"}},
      {"huge height",
       good_with(2, "image_height: 99999999999999999999"),
       {":2:", "field 'image_height'", "outside 1..32768"}},
      {"text width",
       good_with(1, "image_width: wide"),
       {"field 'image_width': expected an integer"}},
      {"unknown model",
       good_with(3, "model: kannala"),
       {":3:8: field 'model': unknown lens model 'kannala'", "Fix: write 'model: fisheye'"}},
      {"negative fx", good_with(4, "fx: -400"), {":4:5: field 'fx': must be positive, got -400"}},
      {"zero fy", good_with(5, "fy: 0"), {"field 'fy': must be positive, got 0"}},
      {"text fx", good_with(4, "fx: abc"), {":4:5: field 'fx': 'abc' is not a number"}},
      {"nan fx", good_with(4, "fx: .nan"), {"field 'fx': the number is not finite"}},
      {"empty fx", good_with(4, "fx:"), {":4:1: field 'fx': the field has no value"}},
      {"list cx", good_with(6, "cx: [1]"), {"field 'cx': expected a number"}},
      {"three coefficients",
       good_with(8, "D: [0, 0, 0]"),
       {":8:4: field 'D': 3 coefficients do not fit the fisheye model", "k1..k4"}},
      {"five fisheye coefficients",
       good_with(8, "D: [0, 0, 0, 0, 0]"),
       {"5 coefficients do not fit the fisheye model"}},
      {"six pinhole coefficients",
       six_pinhole_coefficients,
       {":8:4: field 'D': 6 coefficients do not fit the pinhole model", "4, 5 or 8"}},
      {"text coefficient",
       good_with(8, "D: [0, 0, 0, x]"),
       {"field 'D': element 3 is not a finite number"}},
      {"scalar D", good_with(8, "D: 0"), {"field 'D': expected a list of numbers"}},
      {"ten numbers",
       good_with(9, "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1, 0]"),
       {":9:21: field 'R_site_from_camera': expected 9 numbers (row-major), got 10"}},
      {"scaled",
       good_with(9, "R_site_from_camera: [2, 0, 0, 0, 2, 0, 0, 0, 2]"),
       {"field 'R_site_from_camera': the matrix is not a rotation: RᵀR differs", "determinant +1"}},
      {"reflection",
       good_with(9, "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, -1]"),
       {"field 'R_site_from_camera'", "determinant is -1", "reflection"}},
      {"almost",
       good_with(9, "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1.00001]"),
       {"field 'R_site_from_camera': the matrix is not a rotation"}},
      {"short row",
       good_with(9, "R_site_from_camera: [[1, 0, 0], [0, 1], [0, 0, 1]]"),
       {"field 'R_site_from_camera': expected 3 rows of 3 numbers"}},
      {"short t",
       good_with(10, "t_site_from_camera: [1, 2]"),
       {":10:21: field 't_site_from_camera': expected a list of 3 numbers"}},
      {"empty mask", good_with(11, "mask: ''"), {":11:7: field 'mask': expected a file name"}},
      {"negative rms", good_with(12, "rms: -1"), {"field 'rms': the error is negative"}},
      {"negative view error",
       good_with(13, "per_view_errors: [0.1, -0.2]"),
       {"field 'per_view_errors': element 1 is negative"}},
      {"syntax", good_with(8, "D: [0, 0"), {"YAML syntax error"}},
      {"empty", "", {"the calibration file is empty"}},
      {"list", "- a\n- b\n", {"must be a map of fields"}},
      {"opencv without header",
       "camera_matrix: 1\n",
       {"field 'camera_matrix'", "OpenCV FileStorage file without its header", "%YAML:1.0"}},
  };
  for (const BadCase& bad : cases) {
    SCOPED_TRACE(bad.name);
    const std::string message = load_error(bad.text);
    EXPECT_NE(message.find("camera.yaml"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    for (const std::string& part : bad.expected) {
      EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
    }
  }
}

TEST(LoadCalibration, MissingFileIsAnInputError) {
  TempDir dir;
  EXPECT_THROW(load_calibration(dir.path() / "nowhere.yaml"), InputError);
}

TEST(SaveCalibration, RoundTripsExactly) {
  TempDir dir;
  CameraCalibration c;
  c.file = dir.path() / "in" / "camera.yaml";
  c.image_width = 1920;
  c.image_height = 1080;
  c.model = LensModel::Pinhole;
  c.fx = 0.1 + 0.2;  // not exactly representable in short decimal
  c.fy = 1.0 / 3.0;
  c.cx = 959.5000000000001;
  c.cy = 1e-300;
  c.D = {-0.2731, 0.1e-7, 1.0 / 7.0, -2.0 / 9.0, 5e-17, 0.25, -0.125, std::nextafter(1.0, 2.0)};
  c.R_site_from_camera =
      Eigen::AngleAxisd(0.7, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  c.t_site_from_camera = Vec3(1.0 / 3.0, -7.25, 1e10);
  c.mask = dir.path() / "masks" / "sky #1: mask.png";
  c.rms = 0.123456789012345678;
  c.per_view_errors = {0.1, 1.0 / 3.0, 2.5};

  // Saved elsewhere: the mask is written relative to the new place and still names the file.
  const fs::path out = dir.path() / "out" / "saved.yaml";
  fs::create_directories(out.parent_path());
  save_calibration(c, out);
  const CameraCalibration back = load_calibration(out);
  expect_same(c, back);
  EXPECT_EQ(back.file, out);

  // And the text is stable: saving what was read gives the same bytes.
  const fs::path again = dir.path() / "out" / "again.yaml";
  save_calibration(back, again);
  EXPECT_EQ(read_file(again), read_file(out));

  CameraCalibration fisheye = c;
  fisheye.model = LensModel::Fisheye;
  fisheye.D = {1.0 / 3.0, -1e-5, 2e-7, -3e-9};
  fisheye.mask.clear();
  fisheye.rms.reset();
  fisheye.per_view_errors.clear();
  save_calibration(fisheye, out);
  expect_same(fisheye, load_calibration(out));
}

// The writer's quoting once escaped only quotes and backslashes: a newline came back as a space.
TEST(SaveCalibration, AMaskPathWithANewlineAColonAndQuotesRoundTrips) {
  TempDir dir;
  CameraCalibration c = load_calibration(sky::lens_testing::sample_calibration_file());
  c.mask = dir.path() / "masks" / "sky: \"west\" \\ side\n#1\t.png";
  const fs::path out = dir.path() / "odd.yaml";
  save_calibration(c, out);
  const CameraCalibration back = load_calibration(out);
  EXPECT_EQ(back.mask, c.mask);
  EXPECT_EQ(calibration_to_yaml(back), read_file(out));
}

TEST(SaveCalibration, RefusesAnInvalidCalibration) {
  TempDir dir;
  CameraCalibration c = load_calibration(sky::lens_testing::sample_calibration_file());
  c.fx = -1;
  EXPECT_THROW(save_calibration(c, dir.path() / "bad.yaml"), InputError);
  EXPECT_FALSE(fs::exists(dir.path() / "bad.yaml"));
}

TEST(ValidateCalibration, NamesTheFileAndTheField) {
  const CameraCalibration good = load_calibration(sky::lens_testing::sample_calibration_file());
  EXPECT_NO_THROW(validate(good));
  struct Case {
    std::string field;
    std::function<void(CameraCalibration&)> spoil;
  };
  const std::vector<Case> cases = {
      {"image_width", [](CameraCalibration& c) { c.image_width = 0; }},
      {"image_height", [](CameraCalibration& c) { c.image_height = 40000; }},
      {"fx", [](CameraCalibration& c) { c.fx = std::nan(""); }},
      {"fy", [](CameraCalibration& c) { c.fy = 0; }},
      {"cx", [](CameraCalibration& c) { c.cx = INFINITY; }},
      {"cy", [](CameraCalibration& c) { c.cy = -INFINITY; }},
      {"D",
       [](CameraCalibration& c) {
         c.D = {0, 0, 0, 0, 0};
       }},
      {"D", [](CameraCalibration& c) { c.D[2] = std::nan(""); }},
      {"D",
       [](CameraCalibration& c) {
         c.model = LensModel::Pinhole;
         c.D = {0, 0, 0};
       }},
      {"R_site_from_camera", [](CameraCalibration& c) { c.R_site_from_camera(0, 0) = -1; }},
      {"t_site_from_camera", [](CameraCalibration& c) { c.t_site_from_camera.x() = NAN; }},
      {"rms", [](CameraCalibration& c) { c.rms = -0.5; }},
      {"per_view_errors",
       [](CameraCalibration& c) {
         c.per_view_errors = {1, NAN};
       }},
  };
  for (const Case& bad : cases) {
    SCOPED_TRACE(bad.field);
    CameraCalibration c = good;
    bad.spoil(c);
    try {
      validate(c);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("sky_camera.yaml: field '" + bad.field + "'"), std::string::npos)
          << message;
      EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    }
    EXPECT_THROW(Lens{c}, InputError);  // a lens is never built on nonsense
  }
}

// ---------------------------------------------------------------------------------------------
// OpenCV FileStorage files.

cv::Mat camera_matrix(double fx, double fy, double cx, double cy) {
  return (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1);
}

TEST(LoadCalibration, ReadsOpenCVYamlFisheye) {
  TempDir dir;
  const std::string file = (dir.path() / "fisheye.yml").string();
  {
    cv::FileStorage fs(file, cv::FileStorage::WRITE);
    fs << "calibration_time"
       << "today";
    fs << "image_width" << 1600 << "image_height" << 1200;
    fs << "camera_matrix" << camera_matrix(500.5, 501.25, 799.5, 599.75);
    fs << "distortion_coefficients" << (cv::Mat_<double>(4, 1) << 0.01, -0.002, 3e-4, -4e-5);
    fs << "fisheye" << 1;
    fs << "R_site_from_camera" << (cv::Mat_<double>(3, 3) << 0, 1, 0, 1, 0, 0, 0, 0, -1);
    fs << "avg_reprojection_error" << 0.31;
    fs << "per_view_reprojection_errors" << (cv::Mat_<float>(3, 1) << 0.25f, 0.5f, 0.125f);
  }
  const CameraCalibration c = load_calibration(file);
  EXPECT_EQ(c.model, LensModel::Fisheye);
  EXPECT_EQ(c.image_width, 1600);
  EXPECT_EQ(c.image_height, 1200);
  EXPECT_EQ(c.fx, 500.5);
  EXPECT_EQ(c.fy, 501.25);
  EXPECT_EQ(c.cx, 799.5);
  EXPECT_EQ(c.cy, 599.75);
  EXPECT_EQ(c.D, (std::vector<double>{0.01, -0.002, 3e-4, -4e-5}));
  Eigen::Matrix3d R;
  R << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  EXPECT_EQ(c.R_site_from_camera, R);
  EXPECT_EQ(c.rms, 0.31);
  EXPECT_EQ(c.per_view_errors, (std::vector<double>{0.25, 0.5, 0.125}));

  // Converted to the skylit schema and back: the same calibration.
  const fs::path yaml = dir.path() / "converted.yaml";
  save_calibration(c, yaml);
  expect_same(c, load_calibration(yaml));
}

TEST(LoadCalibration, ReadsOpenCVXmlAndJsonPinhole) {
  TempDir dir;
  for (const std::string name : {"pinhole.xml", "pinhole.json"}) {
    SCOPED_TRACE(name);
    const std::string file = (dir.path() / name).string();
    {
      cv::FileStorage fs(file, cv::FileStorage::WRITE);
      fs << "image_width" << 640 << "image_height" << 480;
      fs << "camera_matrix" << camera_matrix(600, 610, 320.5, 240.5);
      fs << "distortion_coefficients"
         << (cv::Mat_<double>(1, 8) << -0.1, 0.01, 1e-3, -2e-3, 1e-4, 0.02, -0.001, 1e-5);
    }
    const CameraCalibration c = load_calibration(file);
    EXPECT_EQ(c.model, LensModel::Pinhole);
    EXPECT_EQ(c.D.size(), 8u);
    EXPECT_EQ(c.D[7], 1e-5);
    EXPECT_EQ(c.fy, 610);
    EXPECT_EQ(c.R_site_from_camera, Eigen::Matrix3d::Identity());
    EXPECT_FALSE(c.rms.has_value());
  }
}

TEST(LoadCalibration, OpenCVModelStringAndFourCoefficientDefault) {
  TempDir dir;
  const std::string json = dir.write("model.json", R"({
    "image_width": 800, "image_height": 800, "model": "fisheye",
    "camera_matrix": {"type_id": "opencv-matrix", "rows": 3, "cols": 3, "dt": "d",
                      "data": [250.0, 0.0, 399.5, 0.0, 250.0, 399.5, 0.0, 0.0, 1.0]},
    "distortion_coefficients": [0.0, 0.0, 0.0, 0.0],
    "R_site_from_camera": [1, 0, 0, 0, 1, 0, 0, 0, 1],
    "mask": "m.png"
  })")
                               .string();
  const CameraCalibration fisheye = load_calibration(json);
  EXPECT_EQ(fisheye.model, LensModel::Fisheye);
  EXPECT_EQ(fisheye.cx, 399.5);
  EXPECT_EQ(fisheye.mask, dir.path() / "m.png");

  // Four coefficients and no fisheye flag: OpenCV's pinhole model (k1 k2 p1 p2, k3 = 0).
  const std::string yaml =
      dir.write("plain.yml",
                "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n"
                "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
                "   dt: d\n   data: [ 500., 0., 319.5, 0., 500., 239.5, 0., "
                "0., 1. ]\ndistortion_coefficients: [ 0.1, 0.01, 0.001, 0.002 ]\n")
          .string();
  const CameraCalibration pinhole = load_calibration(yaml);
  EXPECT_EQ(pinhole.model, LensModel::Pinhole);
  EXPECT_EQ(pinhole.D, (std::vector<double>{0.1, 0.01, 0.001, 0.002, 0.0}));
}

TEST(LoadCalibration, BadOpenCVFilesNameTheField) {
  const std::string header = "%YAML:1.0\n---\n";
  const std::string K =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 500., 0., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n";
  const std::string size = "image_width: 640\nimage_height: 480\n";
  const std::string D4 = "distortion_coefficients: [ 0., 0., 0., 0. ]\n";
  const std::vector<BadCase> cases = {
      {"no width",
       header + "image_height: 480\n" + K + D4,
       {"field 'image_width': required field is missing"}},
      {"real width",
       header + "image_width: 640.5\nimage_height: 480\n" + K + D4,
       {"field 'image_width': expected an integer"}},
      {"no matrix", header + size + D4, {"field 'camera_matrix': required field is missing"}},
      {"2x2",
       header + size +
           "camera_matrix: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n"
           "   data: [ 1., 0., 0., 1. ]\n" +
           D4,
       {"field 'camera_matrix': expected a 3×3 matrix, got 2×2"}},
      {"skew",
       header + size +
           "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
           "   data: [ 500., 1., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n" +
           D4,
       {"field 'camera_matrix'", "skew is not supported"}},
      {"flag with five",
       header + size + K + "distortion_coefficients: [ 0., 0., 0., 0., 0. ]\nfisheye: 1\n",
       {"field 'distortion_coefficients': 5 coefficients do not fit the fisheye model"}},
      {"three",
       header + size + K + "distortion_coefficients: [ 0., 0., 0. ]\n",
       {"3 coefficients do not fit the pinhole model", "fisheye: 1"}},
      {"model", header + size + K + D4 + "model: kb\n", {"field 'model': unknown lens model 'kb'"}},
      {"reflection",
       header + size + K + D4 + "R_site_from_camera: [ 1, 0, 0, 0, 1, 0, 0, 0, -1 ]\n",
       {"field 'R_site_from_camera'", "reflection"}},
      {"garbage", header + "image_width: [ 1, \n", {"OpenCV cannot"}},
  };
  for (const BadCase& bad : cases) {
    SCOPED_TRACE(bad.name);
    const std::string message = load_error(bad.text, "camera.yml");
    EXPECT_NE(message.find("camera.yml"), std::string::npos) << message;
    EXPECT_NE(message.find("Fix: "), std::string::npos) << message;
    for (const std::string& part : bad.expected) {
      EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Lens models against OpenCV's own functions.

CameraCalibration fisheye_calibration() {
  CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 960;
  c.model = LensModel::Fisheye;
  c.fx = 350.5;
  c.fy = 352.25;
  c.cx = 640.2;
  c.cy = 478.9;
  c.D = {0.05, -0.01, 0.002, -0.0003};
  return c;
}

CameraCalibration pinhole_calibration(bool rational) {
  CameraCalibration c;
  c.image_width = 1280;
  c.image_height = 960;
  c.model = LensModel::Pinhole;
  c.fx = 900.5;
  c.fy = 905.25;
  c.cx = 641.3;
  c.cy = 477.8;
  c.D = {-0.12, 0.03, 0.0015, -0.002, -0.004};
  if (rational) c.D.insert(c.D.end(), {0.05, 0.002, -0.0005});
  return c;
}

// Random unit directions within `max_angle` of the optical axis (+z).
std::vector<Vec3> random_directions(int count, double max_angle, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Vec3> directions;
  for (int i = 0; i < count; ++i) {
    const double theta = max_angle * uniform(random);
    const double phi = 2 * kPi * uniform(random);
    directions.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                            std::cos(theta));
  }
  return directions;
}

cv::Mat K_of(const CameraCalibration& c) { return camera_matrix(c.fx, c.fy, c.cx, c.cy); }

TEST(Lens, FisheyeProjectMatchesOpenCV) {
  const CameraCalibration c = fisheye_calibration();
  const Lens lens(c);
  const std::vector<Vec3> directions = random_directions(500, 85.0 * kPi / 180, 1);
  std::vector<cv::Point3d> points;
  for (const Vec3& d : directions) points.emplace_back(d.x() * 3, d.y() * 3, d.z() * 3);
  std::vector<cv::Point2d> expected;
  cv::fisheye::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_of(c),
                             c.D);
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const std::optional<Vec2> pixel = lens.project(directions[i] * 3);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_NEAR(pixel->x(), expected[i].x, 1e-9);
    EXPECT_NEAR(pixel->y(), expected[i].y, 1e-9);
  }
}

TEST(Lens, FisheyeUnprojectMatchesOpenCV) {
  const CameraCalibration c = fisheye_calibration();
  const Lens lens(c);
  std::vector<cv::Point2d> pixels;
  for (const Vec3& d : random_directions(500, 80.0 * kPi / 180, 2)) {
    pixels.emplace_back(lens.project(d)->x(), lens.project(d)->y());
  }
  std::vector<cv::Point2d> normalised;
  cv::fisheye::undistortPoints(
      pixels, normalised, K_of(c), c.D, cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-15));
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const std::optional<Vec3> d = lens.unproject(Vec2(pixels[i].x, pixels[i].y));
    ASSERT_TRUE(d.has_value());
    EXPECT_NEAR(d->norm(), 1.0, 1e-14);
    EXPECT_NEAR(d->x() / d->z(), normalised[i].x, 1e-9);
    EXPECT_NEAR(d->y() / d->z(), normalised[i].y, 1e-9);
  }
}

TEST(Lens, PinholeProjectMatchesOpenCV) {
  for (const bool rational : {false, true}) {
    SCOPED_TRACE(rational ? "8 coefficients" : "5 coefficients");
    const CameraCalibration c = pinhole_calibration(rational);
    const Lens lens(c);
    const std::vector<Vec3> directions = random_directions(500, 35.0 * kPi / 180, 3);
    std::vector<cv::Point3d> points;
    for (const Vec3& d : directions) points.emplace_back(d.x() * 2, d.y() * 2, d.z() * 2);
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_of(c), c.D, expected);
    for (std::size_t i = 0; i < directions.size(); ++i) {
      const std::optional<Vec2> pixel = lens.project(directions[i] * 2);
      ASSERT_TRUE(pixel.has_value());
      EXPECT_NEAR(pixel->x(), expected[i].x, 1e-9);
      EXPECT_NEAR(pixel->y(), expected[i].y, 1e-9);
    }
  }
}

TEST(Lens, PinholeUnprojectMatchesOpenCV) {
  for (const bool rational : {false, true}) {
    SCOPED_TRACE(rational ? "8 coefficients" : "5 coefficients");
    const CameraCalibration c = pinhole_calibration(rational);
    const Lens lens(c);
    std::vector<cv::Point2d> pixels;
    for (const Vec3& d : random_directions(300, 30.0 * kPi / 180, 4)) {
      pixels.emplace_back(lens.project(d)->x(), lens.project(d)->y());
    }
    std::vector<cv::Point2d> normalised;
    cv::undistortPoints(pixels, normalised, K_of(c), c.D, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT, 200, 0));
    for (std::size_t i = 0; i < pixels.size(); ++i) {
      const std::optional<Vec3> d = lens.unproject(Vec2(pixels[i].x, pixels[i].y));
      ASSERT_TRUE(d.has_value());
      EXPECT_NEAR(d->x() / d->z(), normalised[i].x, 1e-9);
      EXPECT_NEAR(d->y() / d->z(), normalised[i].y, 1e-9);
    }
  }
}

// project(unproject(p)) = p to 1e-9 px over the whole image (where the model reaches).
TEST(Lens, ProjectUnprojectRoundTrips) {
  const std::vector<CameraCalibration> calibrations = {
      fisheye_calibration(), pinhole_calibration(false), pinhole_calibration(true),
      load_calibration(sky::lens_testing::sample_calibration_file())};
  for (const CameraCalibration& c : calibrations) {
    const Lens lens(c);
    int checked = 0;
    for (double y = -0.5; y <= c.image_height - 0.5; y += c.image_height / 37.0) {
      for (double x = -0.5; x <= c.image_width - 0.5; x += c.image_width / 41.0) {
        const std::optional<Vec3> d = lens.unproject(Vec2(x, y));
        if (!d) continue;
        ++checked;
        const std::optional<Vec2> back = lens.project(*d);
        ASSERT_TRUE(back.has_value()) << x << ", " << y;
        EXPECT_NEAR(back->x(), x, 1e-9);
        EXPECT_NEAR(back->y(), y, 1e-9);
      }
    }
    EXPECT_GT(checked, 37 * 41 / 2);
  }
}

TEST(Lens, EquidistantFisheyeImagesBeyondNinetyDegrees) {
  CameraCalibration c = sky::lens_testing::equidistant(1024, 90);
  const Lens lens(c);
  EXPECT_DOUBLE_EQ(lens.max_theta(), kPi);
  // 120° off axis lies 120° × fx from the centre, on the side of the direction.
  const double theta = 120.0 * kPi / 180;
  const std::optional<Vec2> pixel = lens.project(Vec3(std::sin(theta), 0, std::cos(theta)));
  ASSERT_TRUE(pixel.has_value());
  EXPECT_NEAR(pixel->x(), c.cx + c.fx * theta, 1e-9);
  EXPECT_NEAR(pixel->y(), c.cy, 1e-9);
  const std::optional<Vec3> back = lens.unproject(*pixel);
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR(back->z(), std::cos(theta), 1e-12);
  EXPECT_EQ(lens.project(Vec3(0, 0, -1)), std::nullopt);  // straight behind: no unique pixel
  EXPECT_EQ(lens.project(Vec3(0, 0, 0)), std::nullopt);
  EXPECT_EQ(lens.project(Vec3(NAN, 0, 1)), std::nullopt);
  EXPECT_EQ(lens.unproject(Vec2(c.cx + c.fx * 3.2, c.cy)), std::nullopt);  // beyond π
  EXPECT_EQ(lens.unproject(Vec2(NAN, 0)), std::nullopt);
  const std::optional<Vec3> centre = lens.unproject(Vec2(c.cx, c.cy));
  ASSERT_TRUE(centre.has_value());
  EXPECT_EQ(*centre, Vec3(0, 0, 1));
}

TEST(Lens, MaxThetaIsWhereTheModelStopsIncreasing) {
  // θ_d = θ(1 + k1 θ²) turns at 1 + 3 k1 θ² = 0.
  CameraCalibration fisheye = sky::lens_testing::equidistant(1024, 90);
  fisheye.D = {-0.1, 0, 0, 0};
  const Lens lens(fisheye);
  const double turn = std::sqrt(1.0 / 0.3);
  EXPECT_NEAR(lens.max_theta(), turn, 1e-9);
  EXPECT_TRUE(lens.project(Vec3(std::sin(turn - 1e-3), 0, std::cos(turn - 1e-3))).has_value());
  EXPECT_FALSE(lens.project(Vec3(std::sin(turn + 1e-3), 0, std::cos(turn + 1e-3))).has_value());
  const double edge = turn * (1 - 0.1 * turn * turn);  // θ_d at the turn
  EXPECT_TRUE(lens.unproject(Vec2(fisheye.cx + fisheye.fx * edge * 0.999, fisheye.cy)).has_value());
  EXPECT_FALSE(
      lens.unproject(Vec2(fisheye.cx + fisheye.fx * edge * 1.001, fisheye.cy)).has_value());

  // Pinhole r(1 + k1 r²) turns at r² = -1/(3 k1); nothing at or behind the image plane.
  CameraCalibration pinhole = pinhole_calibration(false);
  pinhole.D = {-0.2, 0, 0, 0, 0};
  const Lens barrel(pinhole);
  EXPECT_NEAR(barrel.max_theta(), std::atan(std::sqrt(1.0 / 0.6)), 1e-9);
  EXPECT_FALSE(barrel.project(Vec3(1, 0, 0)).has_value());
  EXPECT_FALSE(barrel.project(Vec3(0.1, 0, -1)).has_value());
  pinhole.D = {0, 0, 0, 0, 0};
  EXPECT_NEAR(Lens(pinhole).max_theta(), kPi / 2, 1e-6);
}

TEST(Lens, SiteFrameAppliesTheRotation) {
  CameraCalibration c = fisheye_calibration();
  c.R_site_from_camera = sky::lens_testing::tilt_about_east(30);
  const Lens lens(c);
  for (const Vec3& d : random_directions(50, 80.0 * kPi / 180, 5)) {
    const Vec3 site = c.R_site_from_camera * d;
    const std::optional<Vec2> pixel = lens.site_to_pixel(site);
    ASSERT_TRUE(pixel.has_value());
    EXPECT_NEAR((*pixel - *lens.project(d)).norm(), 0.0, 1e-9);
    const std::optional<Vec3> back = lens.pixel_to_site(*pixel);
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR((*back - site).norm(), 0.0, 1e-12);
  }
}

}  // namespace
}  // namespace skylit::camera

namespace skylit::camera {
namespace {

std::string lens_refusal(const CameraCalibration& c) {
  try {
    const Lens lens(c);
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

// Numbers that parse but describe no camera are refused naming the field, at once: they once
// kept skylit-shade busy for over a minute.
TEST(Lens, NumbersThatDescribeNoCameraAreRefusedNamingTheField) {
  CameraCalibration sky = sky::lens_testing::equidistant(1024, 90);
  sky.file = "sky_camera.yaml";
  EXPECT_EQ(lens_refusal(sky), "");

  CameraCalibration narrow = sky;
  narrow.fy = 32999999999995.9;  // a typo'd focal length: the image would span 1e-9 degrees
  const std::string fy = lens_refusal(narrow);
  EXPECT_NE(fy.find("sky_camera.yaml"), std::string::npos) << fy;
  EXPECT_NE(fy.find("'fy'"), std::string::npos) << fy;
  EXPECT_NE(fy.find("half a degree"), std::string::npos) << fy;

  CameraCalibration squeezed = sky;
  squeezed.D = {0, 0, 0, 1e30};  // monotonic, but the whole image is a speck of sky
  const std::string d = lens_refusal(squeezed);
  EXPECT_NE(d.find("'D'"), std::string::npos) << d;

  CameraCalibration folded = pinhole_calibration(false);
  folded.file = "hmd_camera.yaml";
  folded.D = {-5.0, 0, 0, 0, 0};  // r(1 − 5r²) turns at r = 0.26, well inside a 1280-pixel image
  const std::string fold = lens_refusal(folded);
  EXPECT_NE(fold.find("'D'"), std::string::npos) << fold;
  EXPECT_NE(fold.find("folds"), std::string::npos) << fold;

  CameraCalibration away = pinhole_calibration(false);
  away.cx = 1e6;
  EXPECT_NE(lens_refusal(away).find("'cx'"), std::string::npos) << lens_refusal(away);

  EXPECT_EQ(lens_refusal(pinhole_calibration(false)), "");
  EXPECT_EQ(lens_refusal(pinhole_calibration(true)), "");
}

}  // namespace
}  // namespace skylit::camera
