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
  const PresetsFile presets(default_presets_file());
  for (const std::string& name : presets.names()) {
    SCOPED_TRACE(name);
    const live::LivePreset p = live::load_live_preset(presets, name);
    std::ofstream(file) << rig.config_text() << "preset: " << name << "\n";
    const live::LiveConfig config = live::load_live_config(file);
    EXPECT_EQ(config.preset, name);
    EXPECT_EQ(config.presets_file, default_presets_file());
    EXPECT_EQ(config.blend.skip_threshold, p.skip_threshold);
    EXPECT_EQ(config.blend.change_threshold, p.change_threshold);
    EXPECT_EQ(config.blend.storage, p.storage);
    EXPECT_EQ(config.render.scale, p.render_scale);
    EXPECT_EQ(config.render.ground_light, p.ground_light);
    EXPECT_EQ(config.render.light_map_precision, p.light_map_precision);
    EXPECT_TRUE(p.ground_light) << "every preset lights the building with the ground";
    EXPECT_EQ(config.sky.smoothing, p.smoothing);
    EXPECT_EQ(config.blend.basis, p.basis);
    EXPECT_GT(p.render_scale, 0.0);
    EXPECT_LE(p.render_scale, 1.0);
  }
}

TEST(ServiceConfig, ConfigKeysOverrideThePreset) {
  const Rig rig;
  const fs::path file = rig.dir() / "preset.yaml";
  const live::LivePreset fast = live::load_live_preset(PresetsFile(default_presets_file()), "fast");
  std::ofstream(file) << rig.config_text() << "preset: fast\nblend:\n  skip_threshold: 0.0125\n  basis: full\n";
  const live::LiveConfig config = live::load_live_config(file);
  EXPECT_EQ(config.blend.skip_threshold, 0.0125);
  EXPECT_EQ(config.blend.basis, blend::BasisForm::Full);
  EXPECT_EQ(config.blend.change_threshold, fast.change_threshold);  // not overridden: the preset's

  // render.light_map_precision overrides the preset's light_map_precision.
  std::ofstream(file) << rig.config_text() << "preset: balanced\nrender:\n  light_map_precision: float\n";
  EXPECT_EQ(live::load_live_config(file).render.light_map_precision, render::LightMapPrecision::Float);
  std::ofstream(file) << rig.config_text() << "preset: fast\nrender:\n  light_map_precision: half\n";
  EXPECT_EQ(live::load_live_config(file).render.light_map_precision, render::LightMapPrecision::Half);
  std::ofstream(file) << rig.config_text() << "render:\n  light_map_precision: double\n";
  const std::string message = skylit::test::error_of([&] { (void)live::load_live_config(file); });
  EXPECT_NE(message.find("render.light_map_precision"), std::string::npos) << message;
  EXPECT_NE(message.find("float"), std::string::npos) << message;

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

TEST(ServiceConfig, ABadLivePresetFieldIsNamed) {
  const Rig rig;
  const fs::path file = rig.dir() / "bad_presets.yaml";
  const auto error_for = [&](const std::string& bake, const std::string& live_section) {
    std::ofstream(file) << "quick:\n  bake: " << bake << "\n  live: " << live_section << "\n";
    try {
      (void)live::load_live_preset(PresetsFile(file), "quick");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string bake = "{frequency: 2, basis: faces, samples: 4}";
  std::string message = error_for(bake, "{basis: pca}");
  EXPECT_NE(message.find("quick.live.basis"), std::string::npos) << message;
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  message = error_for(bake, "{smothing: 1}");
  EXPECT_NE(message.find("smothing"), std::string::npos) << message;
  message = error_for(bake, "{render_scale: 1.5}");
  EXPECT_NE(message.find("render_scale"), std::string::npos) << message;
  message = error_for(bake, "{light_map_precision: double}");
  EXPECT_NE(message.find("quick.live.light_map_precision"), std::string::npos) << message;
  EXPECT_NE(message.find("half"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: faces, samples: 4, pca_components: 4}", "{basis: pca, storage: eac}");
  EXPECT_NE(message.find("live.storage"), std::string::npos) << message;
  EXPECT_EQ(error_for("{frequency: 2, basis: faces, samples: 4, pca_components: 4}", "{basis: pca}"), "");
  fs::remove(file);
}

}  // namespace
}  // namespace skylit::live_test
