// End to end with the corners and quadratics bases: skylit-bake --basis corners|quadratics,
// verify, and skylit-shade on a real sky (its planes and the building), as a user would run them.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli_support.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/sky/radiometry.hpp"
#include "skylit/sky/simulate.hpp"

namespace {

namespace fs = std::filesystem;

using skylit::cli_test::kBin;
using skylit::cli_test::kSource;
using skylit::cli_test::Result;
using skylit::cli_test::TempDir;

Result run(const fs::path& program, const std::string& args) { return skylit::cli_test::run_program(program, args); }

// skylit-bake of the sample site at 24×16 texels with `options`, then skylit-bake verify, whose
// report must name `summary`; the bake's folder.
fs::path bake_and_verify(const fs::path& dir, const std::string& options, const std::string& summary) {
  const fs::path bake = dir / "bake";
  const Result baked = run(kBin / "skylit-bake", (kSource / "config" / "sample_site.yaml").string() + " -o " +
                                                     bake.string() + " " + options +
                                                     " --resolution 24x16 --method raytrace --no-previews -q");
  EXPECT_EQ(baked.status, 0) << baked.output;
  const Result verified = run(kBin / "skylit-bake", "verify " + bake.string());
  EXPECT_EQ(verified.status, 0) << verified.output;
  EXPECT_NE(verified.output.find(summary), std::string::npos) << verified.output;
  return bake;
}

// skylit-shade on the park sky (a low sun) seen by the sample sky camera; its output folder.
fs::path shade_park(const fs::path& bake, const fs::path& dir) {
  const fs::path calib = kSource / "config" / "sky_camera.yaml";
  const skylit::camera::Lens lens(skylit::camera::load_calibration(calib));
  const cv::Mat equirect = skylit::sky::read_sky_image(kSource / "data" / "hdri" / "park.exr");
  const fs::path frame = dir / "park_fisheye.exr";
  skylit::sky::write_sky_exr(frame, skylit::sky::render_fisheye(lens, equirect, {.supersample = 1}));
  const fs::path out = dir / "out";
  const Result shaded = run(kBin / "skylit-shade", "--bake " + bake.string() + " --sky-calib " + calib.string() +
                                                       " --sky " + frame.string() + " -o " + out.string() + " -q");
  EXPECT_EQ(shaded.status, 0) << shaded.output;
  return out;
}

// T of every plane of the sample site at 24 texels across and in [0, 1]; the ground's lowest T.
double check_ratios(const fs::path& out) {
  double ground = 1.0;
  for (const char* plane : {"ground", "wall", "roof"}) {
    const cv::Mat T = skylit::sky::read_sky_image(out / (std::string(plane) + ".exr"));
    EXPECT_EQ(T.cols, 24) << plane;
    double lo = 0, hi = 0;
    cv::minMaxLoc(T.reshape(1), &lo, &hi);
    EXPECT_GE(lo, 0.0) << plane;
    EXPECT_LE(hi, 1.0) << plane;
    if (std::string(plane) == "ground") ground = lo;
  }
  return ground;
}

// building.ply as a viewer reads it: its header's vertex properties in order, then the binary
// records; checks that each vertex's irradiance is finite and not negative, that its sun
// visibility is in [0, 1], that faces turned to the sky get more light than faces turned to the
// ground, and that building.png is a picture.
void check_building(const fs::path& out, std::size_t vertices) {
  std::ifstream in(out / "building.ply", std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t end = all.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  std::istringstream header(all.substr(0, end));
  std::vector<std::pair<std::string, std::string>> properties;  // type, name of each vertex property
  std::size_t count = 0;
  for (std::string line; std::getline(header, line);) {
    std::istringstream words(line);
    std::string first, second, third;
    words >> first >> second >> third;
    if (first == "element" && second == "vertex") count = std::stoul(third);
    if (first == "element" && second == "face") break;
    if (first == "property") properties.emplace_back(second, third);
  }
  ASSERT_EQ(count, vertices);
  std::size_t at = end + std::strlen("end_header\n");
  double up = 0, down = 0;
  int ups = 0, downs = 0;
  for (std::size_t v = 0; v < count; ++v) {
    std::map<std::string, double> value;
    for (const auto& [type, name] : properties) {
      if (type == "float") {
        float f;
        std::memcpy(&f, all.data() + at, 4);
        at += 4;
        value[name] = f;
      } else {
        value[name] = static_cast<unsigned char>(all[at++]);
      }
    }
    for (const char* channel : {"irradiance_r", "irradiance_g", "irradiance_b"}) {
      ASSERT_TRUE(std::isfinite(value.at(channel)) && value.at(channel) >= 0) << "vertex " << v << " " << channel;
    }
    EXPECT_GE(value.at("sun_visibility"), 0.0);
    EXPECT_LE(value.at("sun_visibility"), 1.0);
    const double e = value["irradiance_r"] + value["irradiance_g"] + value["irradiance_b"];
    if (value["nz"] > 0.9) up += e, ++ups;
    if (value["nz"] < -0.9) down += e, ++downs;
  }
  ASSERT_GT(ups, 0);
  ASSERT_GT(downs, 0);
  EXPECT_GT(up / ups, 2 * down / downs) << "faces turned to the sky get more light than faces turned to the ground";
  const cv::Mat picture = cv::imread((out / "building.png").string());
  EXPECT_EQ(picture.cols, 960);
}

TEST(SkylitCorners, BakeVerifyAndShade) {
  TempDir dir;
  const std::string site = (kSource / "config" / "sample_site.yaml").string();
  // One sample per face cannot resolve three corners: refused, with the fix.
  const Result refused = run(kBin / "skylit-bake", site + " -o " + (dir / "refused").string() +
                                                       " --basis corners --resolution 24x16 --method raytrace -q");
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_NE(refused.output.find("--samples 16"), std::string::npos) << refused.output;
  const Result unknown = run(kBin / "skylit-bake", site + " -o " + (dir / "unknown").string() + " --basis vertices -q");
  EXPECT_EQ(unknown.status, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("--basis faces, corners or quadratics"), std::string::npos) << unknown.output;

  const fs::path bake = bake_and_verify(dir.path(), "--basis corners --samples 4", "corners basis, 120 layers");

  const fs::path out = shade_park(bake, dir.path());
  const nlohmann::json sky = nlohmann::json::parse(std::ifstream(out / "sky.json"));
  EXPECT_EQ(sky["basis"], "corners");
  ASSERT_EQ(sky["faces"].size(), 40u);
  for (const auto& face : sky["faces"]) {
    ASSERT_EQ(face["corners"].size(), 3u);
    for (const auto& corner : face["corners"]) {
      EXPECT_EQ(corner["S"].size(), 3u);
      EXPECT_EQ(corner["direction"].size(), 3u);
    }
  }
  check_ratios(out);
  ASSERT_TRUE(sky["building"].is_object()) << sky.dump(2);
  EXPECT_EQ(sky["building"]["ply"], "building.ply");
  check_building(out, sky["building"]["vertices"].get<std::size_t>());
}

TEST(SkylitQuadratics, BakeVerifyAndShade) {
  TempDir dir;
  const std::string site = (kSource / "config" / "sample_site.yaml").string();
  // Four samples per face cannot resolve six functions: refused, with the fix.
  const Result refused = run(kBin / "skylit-bake", site + " -o " + (dir / "refused").string() +
                                                       " --basis quadratics --samples 4 --resolution 24x16 "
                                                       "--method raytrace -q");
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_NE(refused.output.find("at least 6"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("--samples 64"), std::string::npos) << refused.output;

  const fs::path bake = bake_and_verify(dir.path(), "--basis quadratics --samples 8", "quadratics basis, 240 layers");

  const fs::path out = shade_park(bake, dir.path());
  const nlohmann::json sky = nlohmann::json::parse(std::ifstream(out / "sky.json"));
  EXPECT_EQ(sky["basis"], "quadratics");
  ASSERT_EQ(sky["faces"].size(), 40u);
  for (const auto& face : sky["faces"]) {
    ASSERT_EQ(face["quadratics"].size(), 6u);
    EXPECT_EQ(face["quadratics"][0]["function"], "vertex 0");
    EXPECT_EQ(face["quadratics"][5]["function"], "edge 20");
    for (const auto& q : face["quadratics"]) EXPECT_EQ(q["S"].size(), 3u);
  }
  EXPECT_LT(check_ratios(out), 0.9);  // the building's shadow on the ground under the park's sun
}

}  // namespace
