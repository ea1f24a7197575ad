// `preset: NAME` in a skylit-live config: the preset's live settings, overridden by the config's
// own keys; an unknown name refused with the config file, the field and the valid names.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/presets.hpp"

namespace skylit::live_test {
namespace {

TEST(ServiceConfig, PresetSetsTheLiveSettings) {
  const Rig rig;
  const fs::path file = rig.dir() / "preset.yaml";
  for (const Preset& p : load_presets(default_presets_file())) {
    SCOPED_TRACE(p.name);
    std::ofstream(file) << rig.config_text() << "preset: " << p.name << "\n";
    const live::LiveConfig config = live::load_live_config(file);
    EXPECT_EQ(config.preset, p.name);
    EXPECT_EQ(config.presets_file, default_presets_file());
    EXPECT_EQ(config.blend.skip_threshold, p.live.skip_threshold);
    EXPECT_EQ(config.blend.change_threshold, p.live.change_threshold);
    EXPECT_EQ(config.blend.storage == live::BlendSettings::Storage::Unorm8, p.live.storage == "unorm8");
    EXPECT_EQ(config.blend.storage == live::BlendSettings::Storage::Eac, p.live.storage == "eac");
    EXPECT_EQ(config.render.scale, p.live.render_scale);
    EXPECT_EQ(config.sky.smoothing, p.live.smoothing);
    const auto basis = p.live.basis == "pca"    ? live::BlendSettings::Basis::Pca
                       : p.live.basis == "lean" ? live::BlendSettings::Basis::Lean
                                                : live::BlendSettings::Basis::Full;
    EXPECT_EQ(config.blend.basis, basis);
  }
}

TEST(ServiceConfig, ConfigKeysOverrideThePreset) {
  const Rig rig;
  const fs::path file = rig.dir() / "preset.yaml";
  const Preset fast = find_preset(default_presets_file(), "fast");
  std::ofstream(file) << rig.config_text() << "preset: fast\nblend:\n  skip_threshold: 0.0125\n  basis: full\n";
  const live::LiveConfig config = live::load_live_config(file);
  EXPECT_EQ(config.blend.skip_threshold, 0.0125);
  EXPECT_EQ(config.blend.basis, live::BlendSettings::Basis::Full);
  EXPECT_EQ(config.blend.change_threshold, fast.live.change_threshold);  // not overridden: the preset's

  // A presets.yaml beside the config is used instead of the shipped one.
  std::ofstream(rig.dir() / "presets.yaml")
      << "site_tuned:\n  bake: {frequency: 2, basis: faces, samples: 4}\n  live: {change_threshold: 0.0375}\n";
  std::ofstream(file) << rig.config_text() << "preset: site_tuned\n";
  const live::LiveConfig tuned = live::load_live_config(file);
  EXPECT_EQ(tuned.presets_file, rig.dir() / "presets.yaml");
  EXPECT_EQ(tuned.blend.change_threshold, 0.0375);
  fs::remove(rig.dir() / "presets.yaml");
}

TEST(ServiceConfig, AnUnknownPresetNamesTheFileFieldAndValidNames) {
  const Rig rig;
  const fs::path file = rig.dir() / "preset.yaml";
  std::ofstream(file) << rig.config_text() << "preset: turbo\n";
  try {
    (void)live::load_live_config(file);
    FAIL() << "preset turbo accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find("preset"), std::string::npos) << message;
    EXPECT_NE(message.find("turbo"), std::string::npos) << message;
    EXPECT_NE(message.find("fast, balanced, accurate"), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace skylit::live_test
