// skylit-calib stereo run as an installer would: on the real left/right pairs it writes the
// stereo YAML and the rectification check picture; unequal photo counts and too few pairs are
// refused with the fix, leaving an existing output as it was.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../cli/cli_support.hpp"
#include "skylit/base/files.hpp"
#include "skylit/camera/stereo_calibration.hpp"

namespace stereo_cli_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;
using skylit::cli_test::Result;
using skylit::cli_test::TempDir;

const fs::path kStereoPairs = skylit::cli_test::kSource / "data" / "chessboard";

Result run_stereo(const std::string& args) {
  return skylit::cli_test::run_program(skylit::cli_test::kBin / "skylit-calib", "stereo --board 9x6 --square 0.025 " + args);
}

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

// --left and --right with the sample pairs whose numbers are given ("01", "02", ...).
std::string pair_options(const std::vector<std::string>& left, const std::vector<std::string>& right) {
  std::string text = " --left";
  for (const std::string& n : left) text += " " + quoted(kStereoPairs / ("left" + n + ".jpg"));
  text += " --right";
  for (const std::string& n : right) text += " " + quoted(kStereoPairs / ("right" + n + ".jpg"));
  return text;
}

const std::vector<std::string> kAllPairs{"01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14"};

const char* const kEarlier = "# an earlier stereo calibration that a failed run must not touch\n";

TEST(SkylitCalibStereoCli, CalibratesTheRealPairs) {
  const TempDir dir;
  const fs::path out = dir / "stereo.yaml";
  const Result r = run_stereo("-o " + quoted(out) + pair_options(kAllPairs, kAllPairs));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("13 pair(s); the board found in both photos of 13, in one only of 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("baseline 83."), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("RMS reprojection error 0.250 px over both cameras, 13 pair(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("per-pair errors, worst first"), std::string::npos) << r.output;
  const skylit::camera::StereoCalibration s = skylit::camera::load_stereo_calibration(out);
  EXPECT_EQ(s.left.model, skylit::camera::LensModel::Pinhole);
  EXPECT_NEAR(s.baseline_m(), 0.0833, 0.001);
  EXPECT_LT(*s.rms, 0.5);
  EXPECT_EQ(s.per_pair_errors.size(), 13u);
  const cv::Mat picture = cv::imread((dir / "stereo.rectified.jpg").string());
  EXPECT_EQ(picture.size(), cv::Size(1280, 480));
}

TEST(SkylitCalibStereoCli, ModelsPerCameraAndAPairWithTheBoardInOnePhoto) {
  const TempDir dir;
  const fs::path out = dir / "stereo.yaml";
  // A pair whose right photo shows no board: a blank picture of the camera's size.
  cv::imwrite((dir / "blank.png").string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  std::string options = "-o " + quoted(out) + " --left-model fisheye --image-out " + quoted(dir / "check.png") + " --left";
  for (const std::string& n : kAllPairs) options += " " + quoted(kStereoPairs / ("left" + n + ".jpg"));
  options += " --right";
  for (std::size_t k = 0; k < kAllPairs.size(); ++k) {
    options += " " + (k == 3 ? quoted(dir / "blank.png") : quoted(kStereoPairs / ("right" + kAllPairs[k] + ".jpg")));
  }
  const Result r = run_stereo(options);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("the board found in both photos of 12, in one only of 1"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("not used: left04.jpg + blank.png: the board is found in the left photo only"), std::string::npos)
      << r.output;
  const skylit::camera::StereoCalibration s = skylit::camera::load_stereo_calibration(out);
  EXPECT_EQ(s.left.model, skylit::camera::LensModel::Fisheye);
  EXPECT_EQ(s.right.model, skylit::camera::LensModel::Pinhole);
  EXPECT_EQ(s.per_pair_errors.size(), 12u);
  EXPECT_NEAR(s.baseline_m(), 0.0833, 0.002);
  EXPECT_TRUE(fs::exists(dir / "check.png"));
  EXPECT_FALSE(fs::exists(dir / "stereo.rectified.jpg"));
}

TEST(SkylitCalibStereoCli, RefusesUnequalCountsAndTooFewPairsLeavingTheOutput) {
  const TempDir dir;
  const fs::path out = dir / "stereo.yaml";
  std::ofstream(out) << kEarlier;
  std::vector<std::string> fewer = kAllPairs;
  fewer.pop_back();
  Result r = run_stereo("-o " + quoted(out) + pair_options(kAllPairs, fewer));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("13 left photo(s) but 12 right photo(s)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Fix: give the photos in pairs"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(out), kEarlier);
  // Two pairs only: each camera has too few views for its lens.
  r = run_stereo("-o " + quoted(out) + pair_options({"01", "02"}, {"01", "02"}));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("the left camera: 2 usable view(s) of 2 photo(s)"), std::string::npos) << r.output;
  EXPECT_EQ(skylit::read_file(out), kEarlier);
  EXPECT_FALSE(fs::exists(dir / "stereo.rectified.jpg"));
}

}  // namespace stereo_cli_test
