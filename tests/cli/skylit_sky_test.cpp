// End-to-end tests of skylit-sky: runs the program as a user would and reads back what it wrote.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/solar.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;

namespace skylit_sky_test {  // named, not anonymous: the test program is one unity build

using skylit::cli_test::Result;
using SkyTempDir = skylit::cli_test::TempDir;

Result run_sky(const std::string& args) { return skylit::cli_test::run_program(skylit::cli_test::kBin / "skylit-sky", args); }
const fs::path kPark = fs::path(SKYLIT_SOURCE_DIR) / "data" / "hdri" / "park.exr";

// A small equidistant zenith fisheye (96 px across the hemisphere) in the calibration schema.
fs::path write_calibration(const SkyTempDir& dir) {
  const fs::path file = dir / "sky_camera.yaml";
  std::ofstream(file) << "image_width: 96\nimage_height: 96\nmodel: fisheye\n"
                         "fx: 30.2\nfy: 30.2\ncx: 47.5\ncy: 47.5\nD: [0, 0, 0, 0]\n"
                         "R_site_from_camera: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
  return file;
}

// Quoted for the shell. (Appending rather than "'" + s: GCC 12 gives a false -Wrestrict there.)
std::string q(const fs::path& p) {
  std::string quoted(1, '\'');
  quoted += p.string();
  quoted += '\'';
  return quoted;
}

// `text` with every `name` replaced by `value`.
std::string substitute(const std::string& text, const std::string& name, const std::string& value) {
  std::string out;
  std::size_t from = 0;
  for (std::size_t at = text.find(name); at != std::string::npos; at = text.find(name, from)) {
    out.append(text, from, at - from);
    out += value;
    from = at + name.size();
  }
  out.append(text, from, std::string::npos);
  return out;
}

std::vector<std::string> lines_of(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}


TEST(SkylitSky, EquirectToExrAndPng) {
  SkyTempDir dir;
  const fs::path calib = write_calibration(dir);
  const Result exr = run_sky("--calib " + q(calib) + " --equirect " + q(kPark) + " -o " + q(dir / "park.exr") +
                             " --supersample 2");
  ASSERT_EQ(exr.status, 0) << exr.output;
  const cv::Mat radiance = skylit::sky::read_sky_image(dir / "park.exr");
  ASSERT_EQ(radiance.type(), CV_32FC3);
  EXPECT_EQ(radiance.size(), cv::Size(96, 96));
  // Energy of the sky is kept (the 96 px image is coarse: 2%).
  const skylit::camera::Lens lens(skylit::camera::load_calibration(calib));
  const Eigen::Vector3d got = skylit::sky::fisheye_hemisphere_energy(lens, radiance);
  const Eigen::Vector3d expected = skylit::sky::equirect_hemisphere_energy(skylit::sky::read_sky_image(kPark));
  EXPECT_NEAR(got.sum() / expected.sum(), 1.0, 0.02);

  const Result png = run_sky("--calib " + q(calib) + " --equirect " + q(kPark) + " -o " + q(dir / "park.png") +
                             " --exposure 0.5 --azimuth-offset 30");
  ASSERT_EQ(png.status, 0) << png.output;
  const cv::Mat picture = cv::imread((dir / "park.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(picture.type(), CV_8UC3);
  EXPECT_EQ(picture.size(), cv::Size(96, 96));
  EXPECT_GT(cv::mean(picture)[0], 10.0);
}

TEST(SkylitSky, ClearTimeLapseWritesFramesAndCsv) {
  SkyTempDir dir;
  const fs::path calib = write_calibration(dir);
  const fs::path out = dir / "lapse";
  const Result r = run_sky("--calib " + q(calib) + " --clear --lat 34.68 --lon 135.84 --start 2026-06-21T00:00:00Z "
                           "--end 2026-06-21T10:00:00Z --every 2h --turbidity 3 --exposure 0.1 --supersample 1 -o " +
                           q(out));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("skylit-sky: done in"), std::string::npos) << r.output;  // progress lines
  const std::vector<std::string> csv = lines_of(out / "frames.csv");
  ASSERT_EQ(csv.size(), 7u);
  EXPECT_EQ(csv[0], "timestamp,file,sun_azimuth_deg,sun_elevation_deg");
  const skylit::camera::Lens lens(skylit::camera::load_calibration(calib));
  for (int k = 0; k < 6; ++k) {
    SCOPED_TRACE("frame " + std::to_string(k));
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d", k);
    std::stringstream row(csv[static_cast<std::size_t>(k) + 1]);
    std::string timestamp, file, az, el;
    std::getline(row, timestamp, ',');
    std::getline(row, file, ',');
    std::getline(row, az, ',');
    std::getline(row, el, ',');
    EXPECT_EQ(file, std::string(name) + ".exr");
    const auto t = skylit::sky::parse_utc(timestamp);
    EXPECT_EQ(t, skylit::sky::parse_utc("2026-06-21T00:00:00Z") + std::chrono::hours(2 * k));
    const auto sun = skylit::sky::solar_position(t, 34.68, 135.84);
    EXPECT_NEAR(std::stod(az), sun.azimuth_rad * 180 / std::numbers::pi, 1e-3);
    EXPECT_NEAR(std::stod(el), sun.elevation_rad * 180 / std::numbers::pi, 1e-3);

    const cv::Mat frame = skylit::sky::read_sky_image(out / file);
    ASSERT_EQ(frame.type(), CV_32FC3);
    EXPECT_EQ(frame.size(), cv::Size(96, 96));
    const cv::Mat picture = cv::imread((out / (std::string(name) + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(picture.type(), CV_8UC3);
    EXPECT_EQ(picture.size(), cv::Size(96, 96));
    // The brightest pixel is the sun, where the lens puts it.
    cv::Mat channels[3];
    cv::split(frame, channels);
    cv::Point peak;
    cv::minMaxLoc(channels[1], nullptr, nullptr, nullptr, &peak);
    const auto expected = lens.site_to_pixel(sun.direction());
    ASSERT_TRUE(expected.has_value());
    EXPECT_LE(std::hypot(peak.x - expected->x(), peak.y - expected->y()), 1.0);
  }
}

TEST(SkylitSky, OvercastFrame) {
  SkyTempDir dir;
  const fs::path calib = write_calibration(dir);
  const Result r = run_sky("--calib " + q(calib) + " --overcast --zenith-radiance 6 -o " + q(dir / "overcast.exr"));
  ASSERT_EQ(r.status, 0) << r.output;
  const cv::Mat frame = skylit::sky::read_sky_image(dir / "overcast.exr");
  ASSERT_EQ(frame.size(), cv::Size(96, 96));
  EXPECT_NEAR(frame.at<cv::Vec3f>(47, 47)[1], 6.0, 0.05);  // zenith
}

TEST(SkylitSky, BadCalibrationIsReportedWithFileAndField) {
  SkyTempDir dir;
  const fs::path calib = dir / "bad.yaml";
  std::ofstream(calib) << "image_width: 96\nimage_height: 96\nmodel: fisheye\nfx: -30\nfy: 30\ncx: 47.5\n"
                          "cy: 47.5\nD: [0, 0, 0, 0]\n";
  const Result r = run_sky("--calib " + q(calib) + " --overcast -o " + q(dir / "out.exr"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("bad.yaml"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("'fx'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Fix:"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out.exr"));
}


struct BadCase {
  std::string name;
  std::string args;      // after --calib CALIB, with OUT for the output directory
  std::string expected;  // in the message
};

// CTest lists a case by its name, not as a dump of the struct's bytes.
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }


class SkylitSkyBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(SkylitSkyBadInput, ClearErrorAndExitCode2) {
  SkyTempDir dir;
  const fs::path calib = write_calibration(dir);
  const std::string args = substitute(substitute(GetParam().args, "OUT", (dir / "out").string()), "CALIB", calib.string());
  const Result r = run_sky(args);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("skylit-sky: error:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(GetParam().expected), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Fix:"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out" / "frames.csv"));
}

const std::string kLapse = " --clear --lat 34.68 --lon 135.84 --every 1h -o OUT";

INSTANTIATE_TEST_SUITE_P(
    Cases, SkylitSkyBadInput,
    ::testing::Values(
        BadCase{"MissingCalib", "--calib /nonexistent/sky.yaml --overcast -o OUT.exr", "--calib"},
        BadCase{"NoCalib", "--overcast -o OUT.exr", "--calib"},
        BadCase{"NoSky", "--calib CALIB -o OUT.exr", "--clear"},
        BadCase{"TwoSkies", "--calib CALIB --clear --overcast -o OUT.exr", "more than one sky"},
        BadCase{"BadTime", "--calib CALIB" + kLapse + " --start 2026-06-21T00:00:00 --end 2026-06-21T10:00:00Z",
                "no time zone"},
        BadCase{"BadDate", "--calib CALIB" + kLapse + " --start 2026-02-30T00:00:00Z --end 2026-06-21T10:00:00Z",
                "2026-02-30T00:00:00Z"},
        BadCase{"EndBeforeStart", "--calib CALIB" + kLapse + " --start 2026-06-21T10:00:00Z --end 2026-06-21T09:00:00Z",
                "before --start"},
        BadCase{"BadLatitude",
                "--calib CALIB --clear --lat 95 --lon 135.84 --start 2026-06-21T00:00:00Z -o OUT.exr", "--lat"},
        BadCase{"BadLongitude",
                "--calib CALIB --clear --lat 34 --lon 200 --start 2026-06-21T00:00:00Z -o OUT.exr", "--lon"},
        BadCase{"BadInterval", "--calib CALIB --clear --lat 34 --lon 135 --start 2026-06-21T00:00:00Z "
                               "--end 2026-06-21T10:00:00Z --every often -o OUT", "--every"},
        BadCase{"TooManyFrames", "--calib CALIB --clear --lat 34 --lon 135 --start 2000-01-01T00:00:00Z "
                                 "--end 2026-06-21T10:00:00Z --every 1s -o OUT", "frames"},
        BadCase{"BadTurbidity",
                "--calib CALIB --clear --lat 34 --lon 135 --start 2026-06-21T00:00:00Z --turbidity 20 -o OUT.exr",
                "turbidity"},
        BadCase{"ClearWithoutTime", "--calib CALIB --clear --lat 34 --lon 135 -o OUT.exr", "--start"},
        BadCase{"PngWithoutExposure", "--calib CALIB --overcast -o OUT.png", "--exposure"},
        BadCase{"BadExposure", "--calib CALIB --overcast -o OUT.png --exposure -1", "--exposure"},
        BadCase{"BadExtension", "--calib CALIB --overcast -o OUT.jpg", ".exr"},
        BadCase{"BadSupersample", "--calib CALIB --overcast -o OUT.exr --supersample 0", "--supersample"},
        BadCase{"MissingEquirect", "--calib CALIB --equirect /nonexistent/sky.exr -o OUT.exr", "sky.exr"},
        BadCase{"OffsetWithoutEquirect", "--calib CALIB --overcast --azimuth-offset 10 -o OUT.exr",
                "--azimuth-offset"}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) { return param_info.param.name; });


TEST(SkylitSkyResponse, CalibratesACurveFromABracketAndPlotsIt) {
  SkyTempDir dir;
  // A smooth scene spanning three decades, photographed through sRGB at four exposures.
  cv::Mat radiance(64, 64, CV_32FC3);
  for (int y = 0; y < 64; ++y) {
    for (int x = 0; x < 64; ++x) {
      const float l = std::pow(10.0f, -2.0f + 3.0f * static_cast<float>(x + 64 * y) / 4095.0f);
      radiance.at<cv::Vec3f>(y, x) = cv::Vec3f(0.8f * l, l, 0.9f * l);
    }
  }
  const std::array<double, 4> times{0.01, 0.1, 1.0, 10.0};
  std::string args = "response";
  for (std::size_t k = 0; k < times.size(); ++k) {
    const fs::path frame = dir / ("frame" + std::to_string(k) + ".png");
    ASSERT_TRUE(cv::imwrite(frame.string(), skylit::sky::to_8bit(radiance, times[k])));
    args.append(" ").append(frame.string());
  }
  args.append(" --exposure 0.01 0.1 1 10 -o ").append((dir / "curve.yaml").string());
  const Result r = run_sky(args);
  ASSERT_EQ(r.status, 0) << r.output;
  const skylit::sky::ResponseCurve curve = skylit::sky::load_response(dir / "curve.yaml");
  EXPECT_EQ(curve.bits, 8);
  for (const auto& channel : curve.bgr) {
    for (std::size_t code = 1; code < channel.size(); ++code) EXPECT_GE(channel[code], channel[code - 1]);
  }
  EXPECT_TRUE(fs::exists(dir / "curve.png"));
}

TEST(SkylitSkyResponse, OneFrameOrMissingTimesAreErrors) {
  SkyTempDir dir;
  const fs::path frame = dir / "frame.png";
  ASSERT_TRUE(cv::imwrite(frame.string(), cv::Mat(32, 32, CV_8UC3, cv::Scalar(100, 100, 100))));
  Result r = run_sky("response " + frame.string() + " --exposure 1 -o " + (dir / "c.yaml").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("at least 2"), std::string::npos) << r.output;
  r = run_sky("response " + frame.string() + " " + frame.string() + " --exposure 1 -o " + (dir / "c.yaml").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--exposure"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "c.yaml"));
}

}  // namespace
