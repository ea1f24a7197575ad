// config/presets.yaml: every preset loads, and a wrong name or file says what is wrong and where.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "skylit/base/error.hpp"
#include "skylit/base/presets.hpp"

namespace skylit {
namespace {

namespace fs = std::filesystem;
const fs::path kPresets = fs::path(SKYLIT_SOURCE_DIR) / "config/presets.yaml";

std::string error_of(const auto& call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Presets, TheShippedOnesLoad) {
  EXPECT_EQ(default_presets_file(), kPresets);
  const std::vector<Preset> presets = load_presets(kPresets);
  ASSERT_EQ(presets.size(), 3u);
  EXPECT_EQ(preset_names(presets), "fast, balanced, accurate");
  for (const Preset& p : presets) {
    SCOPED_TRACE(p.name);
    EXPECT_EQ(p.bake.frequency % 2, 0);
    EXPECT_TRUE(p.bake.basis == "faces" || p.bake.basis == "corners" || p.bake.basis == "quadratics");
    EXPECT_GE(p.bake.samples, p.bake.basis == "quadratics" ? 6 : p.bake.basis == "corners" ? 3 : 1);
    EXPECT_TRUE(p.live.basis == "full" || p.live.basis == "lean" || p.live.basis == "pca" || p.live.basis == "cropped");
    if (p.live.basis == "pca") {
      EXPECT_GT(p.bake.pca_components, 0);
    }
    EXPECT_TRUE(p.live.storage == "half" || p.live.storage == "unorm8" || p.live.storage == "eac");
    EXPECT_GT(p.live.render_scale, 0.0);
    EXPECT_LE(p.live.render_scale, 1.0);
    const Preset again = find_preset(kPresets, p.name);
    EXPECT_EQ(again.bake.frequency, p.bake.frequency);
    EXPECT_EQ(again.live.skip_threshold, p.live.skip_threshold);
  }
  // The accurate preset is at least as fine as the fast one.
  EXPECT_GE(find_preset(kPresets, "accurate").bake.frequency, find_preset(kPresets, "fast").bake.frequency);
}

TEST(Presets, AnUnknownNameListsTheValidOnesAndTheFile) {
  const std::string message = error_of([] { (void)find_preset(kPresets, "turbo"); });
  EXPECT_NE(message.find("turbo"), std::string::npos) << message;
  EXPECT_NE(message.find(kPresets.string()), std::string::npos) << message;
  EXPECT_NE(message.find("fast, balanced, accurate"), std::string::npos) << message;
}

TEST(Presets, ABadFieldIsNamed) {
  const fs::path file = fs::temp_directory_path() / ("skylit_presets_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(file) << "quick:\n  bake: {frequency: 3, basis: faces, samples: 4}\n  live: {basis: full}\n";
  std::string message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("quick.bake.frequency"), std::string::npos) << message;
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;

  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4}\n  live: {basis: pca}\n";
  message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("quick.live.basis"), std::string::npos) << message;

  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4}\n  live: {smothing: 1}\n";
  message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("smothing"), std::string::npos) << message;
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4}\n  live: {render_scale: 1.5}\n";
  message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("render_scale"), std::string::npos) << message;
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4, pca_components: 4}\n"
                         "  live: {basis: pca, storage: eac}\n";
  message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("live.storage"), std::string::npos) << message;
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4, pca_components: 4, pca_tile: 1}\n"
                         "  live: {basis: pca}\n";
  message = error_of([&] { (void)load_presets(file); });
  EXPECT_NE(message.find("quick.bake.pca_tile"), std::string::npos) << message;
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4, pca_components: 4, pca_tile: 64}\n"
                         "  live: {basis: pca}\n";
  EXPECT_EQ(load_presets(file).front().bake.pca_tile, 64);
  fs::remove(file);
}

}  // namespace
}  // namespace skylit
