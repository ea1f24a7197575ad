// End-to-end tests of skylit-shade: a small bake of the sample site, a real HDR sky rendered into
// the sample sky camera by skylit-sky, shaded as a user would, and every output read back.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "skylit/sky/radiometry.hpp"
#include "cli_support.hpp"

namespace skylit_shade_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;

using skylit::cli_test::kBin;
using skylit::cli_test::kSource;
using skylit::cli_test::Result;

Result run(const fs::path& program, const std::string& args) { return skylit::cli_test::run_program(program, args); }

// One bake and one sky frame for the whole suite (the bake is the slow part).
class SkylitShade : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new skylit::test::TempDir("skylit_shade_cli_");
    const Result bake = run(kBin / "skylit-bake", (kSource / "config" / "sample_site.yaml").string() + " -o " +
                                                      (*dir_ / "bake").string() + " --resolution 48x32 --no-previews -q");
    ASSERT_EQ(bake.status, 0) << bake.output;
    EXPECT_EQ(bake.output, "") << "-q: warnings and errors only";
    const Result sky = run(kBin / "skylit-sky", "--calib " + calib().string() + " --equirect " +
                                                    (kSource / "data" / "hdri" / "park.exr").string() + " -o " +
                                                    (*dir_ / "park.exr").string() + " --supersample 1 -q");
    ASSERT_EQ(sky.status, 0) << sky.output;
    EXPECT_EQ(sky.output, "") << "-q: warnings and errors only";
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path calib() { return kSource / "config" / "sky_camera.yaml"; }
  static std::string common(const fs::path& out) {
    return "--bake " + (*dir_ / "bake").string() + " --sky-calib " + calib().string() + " -o " + out.string();
  }
  static skylit::test::TempDir* dir_;
};
skylit::test::TempDir* SkylitShade::dir_ = nullptr;

TEST_F(SkylitShade, ShadesEveryPlaneAndDescribesTheSky) {
  const fs::path out = *dir_ / "out";
  const Result r = run(kBin / "skylit-shade", common(out) + " --sky " + (*dir_ / "park.exr").string());
  ASSERT_EQ(r.status, 0) << r.output;
  for (const char* plane : {"ground", "wall", "roof"}) {
    const cv::Mat T = skylit::sky::read_sky_image(out / (std::string(plane) + ".exr"));
    EXPECT_EQ(T.cols, 48);
    EXPECT_EQ(T.rows, 32);
    double lo = 0, hi = 0;
    cv::minMaxLoc(T.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.0) << plane;
    EXPECT_LE(hi, 1.0) << plane;
    // The gate shades the ground and the corridor wall; the south roof slope sees open sky.
    if (std::string(plane) != "roof") {
      EXPECT_LT(lo, 0.9) << plane;
    }
    EXPECT_EQ(cv::imread((out / (std::string(plane) + ".png")).string()).cols, 48);
  }
  const nlohmann::json sky = nlohmann::json::parse(std::ifstream(out / "sky.json"));
  ASSERT_EQ(sky["faces"].size(), 40u);
  for (const auto& face : sky["faces"]) {
    for (double s : face["S"]) EXPECT_TRUE(std::isfinite(s) && s >= 0.0);
    EXPECT_GT(face["coverage"].get<double>(), 0.9);
  }
  // park.exr holds a compact, very bright sun: it is found and taken out of the dome.
  ASSERT_FALSE(sky["sun"].is_null()) << sky["sun_reason"];
  EXPECT_GT(sky["sun"]["elevation_deg"].get<double>(), 0.0);
  EXPECT_GT(sky["sun"]["energy"][2].get<double>(), 0.0);
  // Its capture kept the sun's blue alone: the colour is taken as a clear sky's sun's, and said.
  EXPECT_TRUE(sky["sun"]["colour_corrected"].get<bool>());
  EXPECT_EQ(sky["sun"]["measured_energy"][0].get<double>(), 0.0);
  EXPECT_GT(sky["sun"]["energy"][0].get<double>(), 0.5 * sky["sun"]["energy"][2].get<double>());
  EXPECT_EQ(sky["planes"].size(), 3u);
  const cv::Mat overlay = cv::imread((out / "sky_overlay.png").string());
  EXPECT_EQ(overlay.cols, 1024);
}

TEST_F(SkylitShade, TheGroundLightsTheBuildingWithAnAlbedo) {
  // --ground-albedo adds the bake's ground layer: the building's walls get brighter, its roofs
  // (facing up, away from the ground) keep their light.
  const fs::path plain = *dir_ / "plain", lit = *dir_ / "ground";
  ASSERT_EQ(run(kBin / "skylit-shade", common(plain) + " --sky " + (*dir_ / "park.exr").string() + " -q").status, 0);
  const Result r = run(kBin / "skylit-shade", common(lit) + " --ground-albedo 0.3 --sky " + (*dir_ / "park.exr").string() + " -q");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json a = nlohmann::json::parse(std::ifstream(plain / "sky.json"));
  const nlohmann::json b = nlohmann::json::parse(std::ifstream(lit / "sky.json"));
  EXPECT_EQ(b["building"]["ground_albedo"], 0.3);
  for (int c = 0; c < 3; ++c) {
    EXPECT_GT(b["building"]["mean_irradiance"][c].get<double>(), 1.02 * a["building"]["mean_irradiance"][c].get<double>()) << c;
  }
  const Result bad = run(kBin / "skylit-shade", common(lit) + " --ground-albedo 2 --sky " + (*dir_ / "park.exr").string());
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("--ground-albedo"), std::string::npos) << bad.output;
}

TEST_F(SkylitShade, SunOffKeepsTheSunInTheDome) {
  const fs::path out = *dir_ / "off";
  const Result r = run(kBin / "skylit-shade", common(out) + " --sun off --sky " + (*dir_ / "park.exr").string() + " -q");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output.find("info"), std::string::npos) << "-q: warnings and errors only\n" << r.output;
  const nlohmann::json sky = nlohmann::json::parse(std::ifstream(out / "sky.json"));
  EXPECT_TRUE(sky["sun"].is_null());
  EXPECT_EQ(sky["sun_reason"], "sun separation off");
  // --sun-colour measured keeps the pixels' colour.
  const fs::path measured = *dir_ / "measured";
  ASSERT_EQ(run(kBin / "skylit-shade", common(measured) + " --sun-colour measured --sky " + (*dir_ / "park.exr").string() + " -q").status, 0);
  const nlohmann::json kept = nlohmann::json::parse(std::ifstream(measured / "sky.json"));
  EXPECT_FALSE(kept["sun"]["colour_corrected"].get<bool>());
  EXPECT_EQ(kept["sun"]["energy"][0].get<double>(), 0.0);
}

TEST_F(SkylitShade, SourcesListsEverySeparatedSourceTheSunFirst) {
  // Default (--sources 1): the sun alone, listed once.
  const fs::path one = *dir_ / "one";
  Result r = run(kBin / "skylit-shade", common(one) + " --sky " + (*dir_ / "park.exr").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json sky1 = nlohmann::json::parse(std::ifstream(one / "sky.json"));
  ASSERT_EQ(sky1["sources"].size(), 1u);
  EXPECT_TRUE(sky1["sources"][0]["sun"].get<bool>());
  EXPECT_EQ(sky1["sources"][0]["direction"], sky1["sun"]["direction"]);
  EXPECT_EQ(sky1["max_sources"], 1);
  // --sources 4: the sun first, then up to three compact sources, each with its energy.
  const fs::path four = *dir_ / "four";
  r = run(kBin / "skylit-shade", common(four) + " --sources 4 --sky " + (*dir_ / "park.exr").string());
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json sky4 = nlohmann::json::parse(std::ifstream(four / "sky.json"));
  ASSERT_GE(sky4["sources"].size(), 1u);
  ASSERT_LE(sky4["sources"].size(), 4u);
  EXPECT_TRUE(sky4["sources"][0]["sun"].get<bool>());
  EXPECT_EQ(sky4["sources"][0]["direction"], sky1["sun"]["direction"]);
  for (std::size_t k = 1; k < sky4["sources"].size(); ++k) {
    EXPECT_FALSE(sky4["sources"][k]["sun"].get<bool>());
    for (double e : sky4["sources"][k]["energy"]) EXPECT_TRUE(std::isfinite(e) && e >= 0.0);
  }
  EXPECT_TRUE(sky4.contains("sources_reason"));
  for (const auto& plane : sky4["planes"]) {
    EXPECT_GE(plane["min_T"].get<double>(), 0.0);
    EXPECT_LE(plane["mean_T"].get<double>(), 1.0);
  }
  // Several sources need sun separation; fewer than one is no setting.
  for (const char* bad : {" --sources 3 --sun off", " --sources 0"}) {
    r = run(kBin / "skylit-shade", common(*dir_ / "bad_sources") + bad + " --sky " + (*dir_ / "park.exr").string());
    EXPECT_EQ(r.status, 2) << bad << "\n" << r.output;
    EXPECT_NE(r.output.find("--sources"), std::string::npos) << r.output;
  }
}

TEST_F(SkylitShade, AnEightBitBracketMergesToHdr) {
  const cv::Mat hdr = skylit::sky::read_sky_image(*dir_ / "park.exr");
  std::string frames;
  for (double t : {0.25, 1.0, 4.0}) {
    cv::Mat frame8;
    hdr.convertTo(frame8, CV_32FC3, t * 0.5);
    // sRGB encode and clip, as a camera would.
    cv::Mat encoded(hdr.size(), CV_8UC3);
    for (int y = 0; y < hdr.rows; ++y) {
      for (int x = 0; x < hdr.cols; ++x) {
        for (int c = 0; c < 3; ++c) {
          const double v = std::clamp(static_cast<double>(frame8.at<cv::Vec3f>(y, x)[c]), 0.0, 1.0);
          const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
          encoded.at<cv::Vec3b>(y, x)[c] = static_cast<unsigned char>(std::lround(255 * e));
        }
      }
    }
    const fs::path file = *dir_ / ("bracket_" + std::to_string(t) + ".png");
    ASSERT_TRUE(cv::imwrite(file.string(), encoded));
    frames += " --sky " + file.string();
  }
  const fs::path out = *dir_ / "bracket";
  const Result r = run(kBin / "skylit-shade", common(out) + frames + " --exposure 0.25 1 4");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json sky = nlohmann::json::parse(std::ifstream(out / "sky.json"));
  EXPECT_EQ(sky["frames"].size(), 3u);
  EXPECT_TRUE(fs::exists(out / "ground.exr"));
}

// One 8-bit frame of a clear sky over the site, its sun clipped: with the frame's time (--utc)
// and the site's location the sun is found where they put it, and sky.json says how it was found
// and weighed; a time that is not ISO 8601 is refused, naming the option.
TEST_F(SkylitShade, WithTheFramesTimeAClippedSunIsFoundWhereTheSiteSaysItIs) {
  const std::string when = "2026-06-21T02:40:00Z";
  const fs::path frame = *dir_ / "clear8.png";
  const Result sky = run(kBin / "skylit-sky", "--calib " + calib().string() + " --clear --lat 34.69 --lon 135.8 --start " +
                                                  when + " --exposure 0.05 --supersample 1 -o " + frame.string() + " -q");
  ASSERT_EQ(sky.status, 0) << sky.output;
  const fs::path out = *dir_ / "clear8_out";
  const Result r = run(kBin / "skylit-shade", common(out) + " --sky " + frame.string() + " --utc " + when);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream in(out / "sky.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_FALSE(j["sun"].is_null()) << j["sun_reason"];
  EXPECT_EQ(j["sun"]["located_by"], "expected") << j["sun_reason"];
  EXPECT_TRUE(j["sun"]["clipped"].get<bool>());
  EXPECT_EQ(j["sun"]["energy_estimator"], "measured");
  EXPECT_DOUBLE_EQ(j["sun"]["energy_confidence"].get<double>(), 0.0) << "a clipped sun's measured energy is a lower bound";
  const Result bad = run(kBin / "skylit-shade", common(*dir_ / "bad_utc") + " --sky " + frame.string() + " --utc noon");
  EXPECT_EQ(bad.status, 2) << bad.output;
  EXPECT_NE(bad.output.find("noon"), std::string::npos) << bad.output;
}

TEST_F(SkylitShade, BadInputsAreClearErrors) {
  const fs::path sky = *dir_ / "park.exr";
  struct Case {
    std::string args;
    std::string expected;
  };
  // A calibration for another image size.
  const fs::path small_calib = *dir_ / "small.yaml";
  std::ofstream(small_calib) << "image_width: 96\nimage_height: 96\nmodel: fisheye\nfx: 30.2\nfy: 30.2\n"
                                "cx: 47.5\ncy: 47.5\nD: [0, 0, 0, 0]\nR_site_from_camera: [1,0,0, 0,1,0, 0,0,1]\n";
  const std::vector<Case> cases{
      {common(*dir_ / "x1") + " --sky " + sky.string() + " --sun sometimes", "--sun"},
      {"--bake " + (*dir_ / "bake").string() + " --sky-calib " + small_calib.string() + " -o " +
           (*dir_ / "x2").string() + " --sky " + sky.string(),
       "calibration"},
      {"--bake " + dir_->path().string() + " --sky-calib " + calib().string() + " -o " + (*dir_ / "x3").string() +
           " --sky " + sky.string(),
       "not a valid bake"},
      {common(*dir_ / "x4") + " --sky " + sky.string() + " " + sky.string(), "bracket"},
      {common(*dir_ / "x5") + " --sky " + sky.string() + " --exposure 1 2", "--exposure"},
      {common(*dir_ / "x6") + " --sky /nonexistent/sky.exr", "sky.exr"},
  };
  for (const Case& c : cases) {
    const Result r = run(kBin / "skylit-shade", c.args);
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.args << "\n" << r.output;
  }
}

}  // namespace
