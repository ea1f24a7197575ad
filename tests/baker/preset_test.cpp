// The bake sections of config/presets.yaml: every shipped preset's bake loads, typed, and a wrong
// field says what is wrong and where.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/baker/bake_job.hpp"
#include "skylit/baker/preset.hpp"

namespace skylit::baker {
namespace {

namespace fs = std::filesystem;

std::string error_of(const auto& call) {
  try {
    call();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(BakePreset, TheShippedOnesLoad) {
  const PresetsFile presets(default_presets_file());
  for (const std::string& name : presets.names()) {
    SCOPED_TRACE(name);
    const BakePreset p = load_bake_preset(presets, name);
    EXPECT_EQ(p.name, name);
    EXPECT_EQ(p.frequency % 2, 0);
    EXPECT_GE(p.samples, min_samples_per_face(p.basis));
    EXPECT_GE(p.pca_components, 0);
  }
  // The accurate preset is at least as fine as the fast one.
  EXPECT_GE(load_bake_preset(presets, "accurate").frequency, load_bake_preset(presets, "fast").frequency);
}

TEST(BakePreset, ABadFieldIsNamed) {
  const skylit::test::TempDir dir;
  const fs::path file = dir / "presets.yaml";
  const auto error_for = [&](const std::string& bake) {
    std::ofstream(file) << "quick:\n  bake: " << bake << "\n  live: {basis: full}\n";
    return error_of([&] { (void)load_bake_preset(PresetsFile(file), "quick"); });
  };
  std::string message = error_for("{frequency: 3, basis: faces, samples: 4}");
  EXPECT_NE(message.find("quick.bake.frequency"), std::string::npos) << message;
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: hexagons, samples: 4}");
  EXPECT_NE(message.find("quick.bake.basis"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: faces, smaples: 4}");
  EXPECT_NE(message.find("smaples"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: faces, samples: 4, pca_components: 4, pca_tile: 1}");
  EXPECT_NE(message.find("quick.bake.pca_tile"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: faces, samples: 4, refine: -0.2}");
  EXPECT_NE(message.find("quick.bake.refine"), std::string::npos) << message;

  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: corners, samples: 4, pca_components: 4, pca_tile: 64}\n"
                         "  live: {basis: pca}\n";
  const BakePreset p = load_bake_preset(PresetsFile(file), "quick");
  EXPECT_EQ(p.basis, geom::DomeBasis::Corners);
  EXPECT_EQ(p.pca_components, 4);
  EXPECT_EQ(p.pca_tile, 64);
  EXPECT_EQ(p.refine, 0.0);  // the model as it is unless the preset says otherwise
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: corners, samples: 4, refine: 0.2}\n  live: {basis: full}\n";
  EXPECT_EQ(load_bake_preset(PresetsFile(file), "quick").refine, 0.2);
  EXPECT_EQ(load_bake_preset(PresetsFile(file), "quick").light_map, 0.0);  // no light map unless the preset says so

  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: corners, samples: 4, light_map: 0.1, light_map_min_across: 6, "
                         "light_map_components: 32}\n  live: {basis: full}\n";
  const BakePreset mapped = load_bake_preset(PresetsFile(file), "quick");
  EXPECT_EQ(mapped.light_map, 0.1);
  EXPECT_EQ(mapped.light_map_min_area, 0.1);  // skylit-bake's default
  EXPECT_EQ(mapped.light_map_min_across, 6);
  EXPECT_EQ(mapped.light_map_components, 32);
  EXPECT_FALSE(mapped.light_map_pca_only);  // the full form kept unless the preset says otherwise
  message = error_for("{frequency: 2, basis: corners, samples: 4, light_map: 0.1, light_map_pca_only: true}");
  EXPECT_NE(message.find("quick.bake.light_map_pca_only"), std::string::npos) << message;
  EXPECT_NE(message.find("light_map_components"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: corners, samples: 4, light_map: 0.1, light_map_components: 32, light_map_pca_only: 3}");
  EXPECT_NE(message.find("quick.bake.light_map_pca_only"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: corners, samples: 4, light_map_components: 32}");
  EXPECT_NE(message.find("quick.bake.light_map"), std::string::npos) << message;
  EXPECT_NE(message.find("need a light map"), std::string::npos) << message;
  message = error_for("{frequency: 2, basis: corners, samples: 4, light_map: -0.1}");
  EXPECT_NE(message.find("quick.bake.light_map"), std::string::npos) << message;
  fs::remove(file);
}

}  // namespace
}  // namespace skylit::baker
