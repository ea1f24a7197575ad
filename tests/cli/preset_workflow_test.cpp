// The presets' documented workflow, walked as a new user walks it, for every shipped preset:
// `skylit-bake SITE -o B --preset P`, then `preset: P` and `bake: B` in a copy of
// config/demo.yaml, and skylit-live runs it. A preset's bake needs its preset in the config:
// without it skylit-live refuses the bake and says which preset to set.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "cli_support.hpp"
#include "skylit/base/presets.hpp"

namespace skylit::cli_test {
namespace {

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// `text` with every `from` replaced by `to`; fails the test when `from` is not there.
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' is not in the text";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::vector<std::string> shipped_presets() { return PresetsFile(default_presets_file()).names(); }

class PresetWorkflow : public ::testing::TestWithParam<std::string> {
 protected:
  // The sample site at 1/16 of its resolution (the workflow is the same; the bakes take seconds),
  // and the synthetic HMD camera's frames of it.
  void SetUp() override {
    const fs::path config = kSource / "config";
    std::string site = read_text(config / "sample_site.yaml");
    site = replaced(site, "\"../data/models/gate.glb\"", "\"" + (kSource / "data/models/gate.glb").string() + "\"");
    site = replaced(site, "root: \"..\"", "root: \"/\"");  // this copy lies elsewhere
    site = replaced(site, "resolution: [640, 384]", "resolution: [40, 24]");
    site = replaced(site, "resolution: [512, 224]", "resolution: [32, 14]");
    site = replaced(site, "resolution: [256, 110]", "resolution: [16, 7]");
    site_ = dir_.write("sample_site.yaml", site);
    const Result camera = run_program(kBin / "skylit-camera-sim", "--calib " + (config / "hmd_camera.yaml").string() +
                                                                       " -o " + (dir_ / "camera").string() +
                                                                       " --frames 6 --sweep 50 --start-azimuth -120");
    ASSERT_EQ(camera.status, 0) << camera.output;
  }

  // A copy of config/demo.yaml with its paths made absolute, its bake replaced, `preset` added
  // when given, no status port and no window.
  fs::path demo_config(const fs::path& bake, const std::string& preset) const {
    const fs::path config = kSource / "config";
    std::string text = read_text(config / "demo.yaml");
    text = replaced(text, "root: ..", "root: /");  // the files it names lie in several folders
    text = replaced(text, "site: sample_site.yaml", "site: " + site_.string());
    text = replaced(text, "bake: ../build/demo/bake", "bake: " + bake.string() + (preset.empty() ? "" : "\npreset: " + preset));
    text = replaced(text, "  calibration: sky_camera.yaml", "  calibration: " + (config / "sky_camera.yaml").string());
    text = replaced(text, "    calibration: sky_camera.yaml", "    calibration: " + (config / "sky_camera.yaml").string());
    text = replaced(text, "  calibration: hmd_camera.yaml", "  calibration: " + (config / "hmd_camera.yaml").string());
    text = replaced(text, "path: ../build/demo/camera", "path: " + (dir_ / "camera").string());
    text = replaced(text, "csv: ../build/demo/camera/poses.csv", "csv: " + (dir_ / "camera/poses.csv").string());
    text = replaced(text, "record: ../build/demo/live.mp4", "record: " + (dir_ / "live.mp4").string());
    text = replaced(text, "status:\n  listen: 127.0.0.1:8080", "");
    return dir_.write(preset.empty() ? "demo_no_preset.yaml" : "demo_" + preset + ".yaml", text);
  }

  TempDir dir_{"skylit_preset_workflow_"};
  fs::path site_;
};

TEST_P(PresetWorkflow, APresetsBakeRunsInTheLiveServiceWithThatPreset) {
  const std::string& preset = GetParam();
  const fs::path bake = dir_ / ("bake_" + preset);
  // A preset's light map at 0.1 m takes minutes to trace; at 0.4 m over the large faces alone it
  // takes seconds, and the preset's other light-map settings (its PCA form) still apply.
  const YAML::Node bake_section = PresetsFile(default_presets_file()).section(preset, "bake").node;
  const bool light_map = bake_section["light_map"] && bake_section["light_map"].as<double>() > 0;
  const Result baked = run_program(kBin / "skylit-bake", site_.string() + " -o " + bake.string() + " --preset " + preset +
                                                             " --no-previews" +
                                                             (light_map ? " --light-map 0.4 --light-map-min-area 1" : ""));
  ASSERT_EQ(baked.status, 0) << baked.output;
  if (bake_section["light_map_components"]) {
    const nlohmann::json manifest = nlohmann::json::parse(read_text(bake / "manifest.json"));
    EXPECT_EQ(manifest["light_map"]["pca"]["components"].get<int>(), bake_section["light_map_components"].as<int>())
        << "the preset's light map components";
  }

  const Result live = run_program(kBin / "skylit-live", demo_config(bake, preset).string() + " --headless --frames 5");
  ASSERT_EQ(live.status, 0) << live.output;
  // The frame log beside the recording: a header and a row per composited frame.
  std::istringstream log(read_text(dir_ / "live.csv"));
  int rows = 0;
  for (std::string line; std::getline(log, line);) rows += line.empty() ? 0 : 1;
  EXPECT_EQ(rows, 1 + 5) << read_text(dir_ / "live.csv");

  // The same bake without `preset:` is refused, naming the preset to set.
  const Result refused = run_program(kBin / "skylit-live", demo_config(bake, "").string() + " --headless --frames 5");
  EXPECT_EQ(refused.status, 2) << refused.output;
  EXPECT_NE(refused.output.find("made with preset '" + preset + "'"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("preset: " + preset), std::string::npos) << refused.output;
}

INSTANTIATE_TEST_SUITE_P(Shipped, PresetWorkflow, ::testing::ValuesIn(shipped_presets()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

}  // namespace
}  // namespace skylit::cli_test
