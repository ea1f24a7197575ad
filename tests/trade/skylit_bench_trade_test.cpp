// skylit-bench trade on a tiny grid (one bake, five forms, two bit depths; the park sky; planes at
// 1/32; a 160×120 frame): every field of trade.json, the plot, and a Pareto front that is
// exactly the non-dominated settings.
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../cli/cli_support.hpp"

namespace skylit::trade_test {
namespace {

namespace fs = std::filesystem;
using cli_test::kBin;
using cli_test::kSource;

std::string read_all(const fs::path& file) {
  std::ostringstream out;
  out << std::ifstream(file).rdbuf();
  return out.str();
}

// skylit-bench trade on the sample site, its cameras and the bundled skies; the grid follows.
std::string trade_command() {
  return "trade --site " + (kSource / "config/sample_site.yaml").string() + " --calib " +
         (kSource / "config/sky_camera.yaml").string() + " --hmd-camera " + (kSource / "config/hmd_camera.yaml").string() +
         " --skies " + (kSource / "data/hdri").string();
}

// skylit-bench trade on `grid` (skies, bakes and settings) with the tests' small frame and few
// repetitions, the results in `out`.
cli_test::Result run_small_trade(const std::string& grid, const fs::path& out) {
  return cli_test::run_program(kBin / "skylit-bench",
                               trade_command() + " " + grid +
                                   " --frame-width 160 --frame-height 120 --frame-repeats 3 --blend-repeats 2 --timing-scale 8"
                                   " --supersample 1 --out " + out.string());
}

bool dominates(const nlohmann::json& a, const nlohmann::json& b) {
  const double ac = a.at("cost_ms"), bc = b.at("cost_ms"), ae = a.at("rms"), be = b.at("rms");
  return ac <= bc && ae <= be && (ac < bc || ae < be);
}

TEST(SkylitBenchTrade, TinyGridWritesTheTableThePlotAndTheParetoFront) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const cli_test::Result result = run_small_trade(
      "--sky park --frequencies 2 --bases faces --samples 3 --texel-scales 32 --forms full,lean,cropped,pca2,pca2t4 --bits 16,8"
      " --sun on --skip-thresholds 0,0.01",
      out);
  ASSERT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find("bake 1/1"), std::string::npos) << result.output;  // progress

  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  // The reference integrates the continuous sky unless told otherwise (4 × 4 sub-directions).
  EXPECT_EQ(doc.at("reference_supersample"), 4);
  const auto& settings = doc.at("settings");
  // full, lean and cropped at 16 and 8 bits, pca2 and pca2t4 (clustered) at 16 bits only; two S
  // thresholds: 16 settings.
  ASSERT_EQ(settings.size(), 16u);
  for (const char* key : {"label", "frequency", "basis", "samples", "texel_scale", "form", "bits", "sun_separation",
                          "skip_threshold", "change_threshold", "smoothing", "render_scale", "rms", "p99", "max",
                          "rms_per_sky", "edge_displacement_m", "edge_displacement_deg", "bake_seconds", "bake_bytes",
                          "gpu_bytes", "layers", "skipped_layers", "blend_ms", "blend_cpu_ms", "frame_ms", "frame_cpu_ms",
                          "whole_frame_ms", "whole_frame_cpu_ms", "cost_ms", "frames_per_second", "pareto", "sequence",
                          "building", "refine", "vertices"}) {
    for (const auto& s : settings) ASSERT_TRUE(s.contains(key)) << key << " missing in " << s.dump();
  }
  for (const auto& s : settings) {
    SCOPED_TRACE(s.at("label").get<std::string>());
    EXPECT_GT(s.at("rms").get<double>(), 0.0);
    EXPECT_LE(s.at("rms").get<double>(), s.at("max").get<double>());
    EXPECT_LE(s.at("p99").get<double>(), s.at("max").get<double>());
    EXPECT_GT(s.at("bake_bytes").get<double>(), 0.0);
    EXPECT_GT(s.at("gpu_bytes").get<double>(), 0.0);
    EXPECT_GT(s.at("frame_ms").get<double>(), 0.0);
    EXPECT_GT(s.at("blend_ms").get<double>(), 0.0);
    EXPECT_TRUE(s.at("edge_displacement_deg").is_number()) << "park has a sun";
    EXPECT_TRUE(s.at("rms_per_sky").contains("park"));
    EXPECT_TRUE(s.at("sequence").is_null()) << "no --sequence";
    // The building against a reference with a ground of albedo 0.2 (the default): the bake's
    // ground layer takes part of its error away even on this coarse dome (ν = 2, 3 samples)
    // against a coarse reference (the ground's T in 2 m texels): 0.044 against 0.062.
    const nlohmann::json& building = s.at("building");
    EXPECT_GT(building.at("rms").get<double>(), 0.0);
    EXPECT_LT(building.at("rms").get<double>(), 0.85 * building.at("without_ground_layer").at("rms").get<double>());
    // Inside the triangles, interpolated from few vertices, it is worse than at them.
    EXPECT_GT(building.at("inside_triangles_by_area").at("rms").get<double>(), building.at("rms").get<double>());
    EXPECT_EQ(s.at("refine"), 0.0);
  }
  // 8-bit layers take half the GPU memory of half floats; the PCA form less than either.
  const auto find = [&](const std::string& form, int bits) {
    for (const auto& s : settings) {
      if (s.at("form") == form && s.at("bits") == bits && s.at("skip_threshold") == 0.0) return s;
    }
    ADD_FAILURE() << form << " " << bits;
    return nlohmann::json();
  };
  EXPECT_EQ(find("full", 16).at("gpu_bytes").get<double>(), 2 * find("full", 8).at("gpu_bytes").get<double>());
  EXPECT_LT(find("pca2", 16).at("gpu_bytes").get<double>(), find("full", 8).at("gpu_bytes").get<double>());
  // The cropped form is the lean one read only inside its rectangles: the same T (within 1e-3),
  // the same layers, and less GPU memory (the GPU blend keeps its rectangles, in pages).
  for (const int bits : {16, 8}) {
    SCOPED_TRACE(bits);
    EXPECT_NEAR(find("cropped", bits).at("rms").get<double>(), find("lean", bits).at("rms").get<double>(), 1e-3);
    EXPECT_LT(find("cropped", bits).at("gpu_bytes").get<double>(), find("lean", bits).at("gpu_bytes").get<double>());
    EXPECT_EQ(find("cropped", bits).at("layers"), find("lean", bits).at("layers"));
  }
  // Clustered PCA reads as many layers as the plain form of the same K.
  EXPECT_EQ(find("pca2t4", 16).at("layers"), find("pca2", 16).at("layers"));
  std::printf("measured: park, K = 2: RMS %.4f for one set per plane, %.4f with tiles of 4 texels\n",
              find("pca2", 16).at("rms").get<double>(), find("pca2t4", 16).at("rms").get<double>());

  // The front: exactly the settings no other one dominates, and listed in "pareto".
  std::vector<std::size_t> front;
  for (std::size_t k = 0; k < settings.size(); ++k) {
    bool dominated = false;
    for (const auto& other : settings) dominated = dominated || dominates(other, settings[k]);
    EXPECT_EQ(settings[k].at("pareto").get<bool>(), !dominated) << settings[k].dump();
    if (!dominated) front.push_back(k);
  }
  EXPECT_FALSE(front.empty());
  EXPECT_EQ(doc.at("pareto").get<std::vector<std::size_t>>(), front);

  const std::string svg = read_all(out / "trade.svg");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);   // the front
  std::size_t circles = 0;
  for (std::size_t at = svg.find("<circle"); at != std::string::npos; at = svg.find("<circle", at + 1)) ++circles;
  EXPECT_EQ(circles, settings.size());
  const std::string md = read_all(out / "trade.md");
  EXPECT_NE(md.find("| Pareto |"), std::string::npos);
  EXPECT_NE(md.find("building RMS / p99 (without the ground layer)"), std::string::npos);
}

// The separated sources' count is a setting (sky.max_sources): under the warehouse's lamps, eight
// sources (each a ray-cast area light of its pixels in the blend, each lamp a shadow map and a
// per-vertex term in the frame) halve the error of one; the sun off has no sources.
TEST(SkylitBenchTrade, SeparatedSourcesAreASettingOfTheGrid) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const cli_test::Result result = run_small_trade(
      "--sky warehouse --frequencies 2 --bases faces --samples 3 --texel-scales 32 --forms full --bits 16"
      " --sun on,off --sources 1,8 --skip-thresholds 0",
      out);
  ASSERT_EQ(result.status, 0) << result.output;
  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  const auto& settings = doc.at("settings");
  ASSERT_EQ(settings.size(), 3u);  // sun on with 1 and 8 sources, sun off
  std::map<int, double> rms;
  for (const auto& s : settings) rms[s.at("sources").get<int>()] = s.at("rms").get<double>();
  ASSERT_EQ(rms.size(), 3u);
  ASSERT_TRUE(rms.count(0) && rms.count(1) && rms.count(8));
  std::printf("measured: warehouse at 1/32, faces K = 3: RMS %.4f without the sun's separation, %.4f with one source, "
              "%.4f with eight\n", rms[0], rms[1], rms[8]);
  EXPECT_LT(rms[8], 0.75 * rms[1]);
  const std::string md = read_all(out / "trade.md");
  EXPECT_NE(md.find("| on+7 |"), std::string::npos) << md;
  EXPECT_NE(result.output.find("sun+7"), std::string::npos) << result.output;
}

// A bake of the model refined where its light changes (skylit-bake --refine) and one whose vertices
// are fitted to the light inside their triangles (--vertex-fit) are settings of the grid: the
// building inside its triangles, by area, far closer to its reference under park's low sun
// (measured at 1/32, faces K = 3: 0.2291, fitted 0.0651; refined 0.0920, fitted 0.0595).
TEST(SkylitBenchTrade, ARefinedModelAndFittedVerticesAreSettingsMeasuredInsideTheTriangles) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const cli_test::Result result = run_small_trade(
      "--sky park --frequencies 2 --bases faces --samples 3 --texel-scales 32 --refine 0,0.2 --vertex-fits 0,3 --forms full"
      " --bits 16 --sun on --skip-thresholds 0",
      out);
  ASSERT_EQ(result.status, 0) << result.output;
  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  const auto& settings = doc.at("settings");
  ASSERT_EQ(settings.size(), 4u);
  std::map<std::pair<double, int>, nlohmann::json> by_bake;
  for (const auto& s : settings) by_bake[{s.at("refine").get<double>(), s.at("vertex_fit").get<int>()}] = s;
  ASSERT_EQ(by_bake.size(), 4u) << doc.dump(2);
  const auto inside = [&](double refine, int fit) {
    return by_bake.at({refine, fit}).at("building").at("inside_triangles_by_area").at("rms").get<double>();
  };
  const nlohmann::json &plain = by_bake.at({0.0, 0}), &refined = by_bake.at({0.2, 0});
  EXPECT_GT(refined.at("vertices").get<double>(), 1.3 * plain.at("vertices").get<double>());
  // The fit changes values, not the model.
  EXPECT_EQ(by_bake.at({0.0, 3}).at("vertices"), plain.at("vertices"));
  EXPECT_EQ(by_bake.at({0.2, 3}).at("vertices"), refined.at("vertices"));
  std::printf("measured: park at 1/32, faces K = 3, the building inside its triangles: %.4f (%d vertices), fitted %.4f; "
              "refined at 0.2 %.4f (%d vertices), fitted %.4f\n",
              inside(0.0, 0), plain.at("vertices").get<int>(), inside(0.0, 3), inside(0.2, 0), refined.at("vertices").get<int>(),
              inside(0.2, 3));
  EXPECT_LT(inside(0.2, 0), 0.75 * inside(0.0, 0));
  EXPECT_LT(inside(0.0, 3), 0.75 * inside(0.0, 0));
  EXPECT_LT(inside(0.2, 3), 0.75 * inside(0.2, 0));
  // The planes' T is the plain bake's in every row: neither moves a surface.
  for (const auto& s : settings) {
    EXPECT_NEAR(s.at("rms").get<double>(), plain.at("rms").get<double>(), 0.1 * plain.at("rms").get<double>()) << s.at("label");
  }
  EXPECT_NE(refined.at("label").get<std::string>().find("_r0.2"), std::string::npos);
  EXPECT_NE(by_bake.at({0.0, 3}).at("label").get<std::string>().find("_f3"), std::string::npos);
  EXPECT_NE(read_all(out / "trade.md").find("inside the triangles, by area"), std::string::npos);
}

// A light map (skylit-bake --light-map) is a setting of the grid: the building inside its
// triangles shown from its texels where it covers them, closer to its reference than from the
// fitted vertices alone under park's low sun (at 1/32, faces K = 3: 0.0651, with 0.25 m texels
// 0.0501, the rest the coarse dome's); the planes' T unchanged.
TEST(SkylitBenchTrade, ALightMapIsASettingMeasuredInsideTheTriangles) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const cli_test::Result result = run_small_trade(
      "--sky park --frequencies 2 --bases faces --samples 3 --texel-scales 32 --vertex-fits 3 --light-maps 0,0.25 --forms full"
      " --bits 16 --sun on --skip-thresholds 0 --light-map-components 16",
      out);
  ASSERT_EQ(result.status, 0) << result.output;
  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  // The map in its PCA form (16 components per chart of the 40 layers): what the frame draws and
  // the error measures.
  EXPECT_EQ(doc.at("light_map_components"), 16);
  const auto& settings = doc.at("settings");
  ASSERT_EQ(settings.size(), 2u);
  std::map<double, nlohmann::json> by_map;
  for (const auto& s : settings) by_map[s.at("light_map").get<double>()] = s;
  ASSERT_EQ(by_map.size(), 2u) << doc.dump(2);
  const auto inside = [&](double texel) { return by_map.at(texel).at("building").at("inside_triangles_by_area").at("rms").get<double>(); };
  std::printf("measured: park at 1/32, faces K = 3, fitted vertices: the building inside its triangles %.4f; with a 0.25 m light map "
              "(16 components per chart) %.4f\n",
              inside(0.0), inside(0.25));
  EXPECT_LT(inside(0.25), 0.85 * inside(0.0));  // measured 0.0651 → 0.0501 (the full form); the coarse dome's error stays
  EXPECT_NEAR(by_map.at(0.25).at("rms").get<double>(), by_map.at(0.0).at("rms").get<double>(), 1e-9) << "the planes' T is the same";
  EXPECT_NE(by_map.at(0.25).at("label").get<std::string>().find("_lm0.25"), std::string::npos);
  EXPECT_GT(by_map.at(0.25).at("bake_bytes").get<double>(), by_map.at(0.0).at("bake_bytes").get<double>());
  EXPECT_EQ(doc.at("light_map_precision"), "float");
  // A new sky's cost counts the building's sum beside the blend.
  for (const auto& [texel, s] : by_map) {
    SCOPED_TRACE(texel);
    EXPECT_GT(s.at("building_sum_ms").get<double>(), 0.0);
    EXPECT_NEAR(s.at("whole_frame_ms").get<double>(),
                s.at("frame_ms").get<double>() + s.at("blend_ms").get<double>() + s.at("building_sum_ms").get<double>(), 1e-9);
    // One sky: its own figure is the pooled one.
    const nlohmann::json& building = s.at("building");
    EXPECT_DOUBLE_EQ(building.at("inside_triangles_by_area_per_sky").at("park").at("rms").get<double>(),
                     building.at("inside_triangles_by_area").at("rms").get<double>());
  }
  EXPECT_NE(read_all(out / "trade.md").find("each sky alone"), std::string::npos);
}

// --live-seconds: each setting's frame rate also from skylit-live itself, run on the setting's bake
// with a 60 Hz camera and a changing sky; its own /status in the table.
TEST(SkylitBenchTrade, TheServiceItselfGivesEachSettingsFrameRate) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const cli_test::Result result = run_small_trade(
      "--sky park --frequencies 2 --bases faces,corners --samples 3 --texel-scales 32 --forms full --bits 16"
      " --sun on --skip-thresholds 0 --live-seconds 1",
      out);
  ASSERT_EQ(result.status, 0) << result.output;
  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  ASSERT_EQ(doc.at("settings").size(), 2u);
  for (const auto& s : doc.at("settings")) {
    SCOPED_TRACE(s.at("label").get<std::string>());
    const auto& live = s.at("live");
    ASSERT_TRUE(live.is_object()) << s.dump();
    EXPECT_GE(live.at("composited").get<std::int64_t>(), 30);
    EXPECT_GT(live.at("frames_per_second").get<double>(), 0.0);
    EXPECT_GT(live.at("frame_p50_ms").get<double>(), 0.0);
    EXPECT_GE(live.at("camera_frames").get<std::int64_t>(), live.at("composited").get<std::int64_t>());
    EXPECT_TRUE(live.at("blend_device") == "cpu" || live.at("blend_device") == "gpu") << live.dump();
  }
  EXPECT_NE(read_all(out / "trade.md").find("service frames/s"), std::string::npos);
  EXPECT_NE(result.output.find("service: "), std::string::npos) << result.output;
}

// --sequence on a tiny grid: ΔS thresholds 0 and 0.05, smoothings 0 and 10 s, 24 skies with a
// passing cloud. Threshold 0 without smoothing blends every frame and is the still-sky path; a
// large threshold blends fewer and stays within its bound; a long time constant lags the cloud.
TEST(SkylitBenchTrade, SequenceMeasuresTheChangeThresholdAndTheSmoothing) {
  const test::TempDir dir;
  const fs::path out = dir / "trade";
  const double large = 0.05;
  const cli_test::Result result = cli_test::run_program(
      kBin / "skylit-bench",
      trade_command() + " --sky park --frequencies 2 --bases faces --samples 3 --texel-scales 32 --forms full --bits 16 --sun on"
          " --skip-thresholds 0 --change-thresholds 0,0.05 --smoothings 0,10 --frame-width 160 --frame-height 120"
          " --frame-repeats 2 --blend-repeats 2 --timing-scale 8 --supersample 1 --sequence --sequence-frames 24 --out " +
          out.string());
  ASSERT_EQ(result.status, 0) << result.output;
  const nlohmann::json doc = nlohmann::json::parse(read_all(out / "trade.json"));
  ASSERT_TRUE(doc.at("sequence").is_object());
  EXPECT_EQ(doc.at("sequence").at("frames"), 24);
  const auto& settings = doc.at("settings");
  ASSERT_EQ(settings.size(), 4u);
  const auto find = [&](double change, double smoothing) {
    for (const auto& s : settings) {
      if (s.at("change_threshold") == change && s.at("smoothing") == smoothing) return s.at("sequence");
    }
    ADD_FAILURE() << change << " " << smoothing;
    return nlohmann::json();
  };
  const nlohmann::json base = find(0.0, 0.0), thresholded = find(large, 0.0), smoothed = find(0.0, 10.0);
  ASSERT_TRUE(base.is_object() && thresholded.is_object() && smoothed.is_object());
  for (const auto* q : {&base, &thresholded, &smoothed}) {
    for (const char* key : {"rms", "rms_worst", "p99", "p99_worst", "max", "still_rms", "still_max", "blend_fraction", "frames"}) {
      ASSERT_TRUE(q->contains(key)) << key;
    }
    ASSERT_EQ(q->at("frames").at("rms").size(), 24u);
    EXPECT_GT(q->at("rms").get<double>(), 0.0);
    EXPECT_LE(q->at("rms").get<double>(), q->at("rms_worst").get<double>());
  }
  const auto frames = [](const nlohmann::json& q, const char* key) { return q.at("frames").at(key).get<std::vector<double>>(); };

  // Threshold 0, no smoothing: every plane of every frame re-blends, and each frame's error is
  // the still-sky error of that frame.
  EXPECT_EQ(base.at("blend_fraction").get<double>(), 1.0);
  EXPECT_EQ(frames(base, "rms"), frames(base, "still_rms"));
  EXPECT_EQ(frames(base, "max"), frames(base, "still_max"));

  // A large threshold: fewer re-blends, a larger error, but within the bound it implies: the
  // kept T is within the threshold of a fresh blend, texel by texel.
  EXPECT_LT(thresholded.at("blend_fraction").get<double>(), base.at("blend_fraction").get<double>());
  EXPECT_GE(thresholded.at("rms").get<double>(), base.at("rms").get<double>());
  const auto rms = frames(thresholded, "rms"), still_rms = frames(thresholded, "still_rms");
  const auto max = frames(thresholded, "max"), still_max = frames(thresholded, "still_max");
  for (std::size_t k = 0; k < rms.size(); ++k) {
    EXPECT_LE(max[k], still_max[k] + large + 1e-4) << "frame " << k;
    EXPECT_LE(rms[k], still_rms[k] + large + 1e-4) << "frame " << k;
  }
  EXPECT_EQ(frames(thresholded, "still_rms"), frames(base, "still_rms"));  // the same skies and estimates

  // A long time constant lags the passing cloud: the error grows, most in the worst frame.
  EXPECT_EQ(smoothed.at("blend_fraction").get<double>(), 1.0);
  EXPECT_GT(smoothed.at("rms").get<double>(), 1.2 * base.at("rms").get<double>());
  EXPECT_GT(smoothed.at("rms_worst").get<double>(), 1.5 * base.at("rms_worst").get<double>());

  const std::string md = read_all(out / "trade.md");
  EXPECT_NE(md.find("Sky sequence"), std::string::npos);
}

}  // namespace
}  // namespace skylit::trade_test
