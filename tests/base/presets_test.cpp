// config/presets.yaml: every preset loads, and a wrong name or file says what is wrong and where.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
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

TEST(Presets, TheShippedFileHasThreePresetsWithBothSections) {
  // The shipped file, as the build copied it beside the programs (share/skylit, as installed).
  EXPECT_EQ(default_presets_file(), fs::path(SKYLIT_BINARY_DIR) / "share" / "skylit" / "presets.yaml");
  EXPECT_EQ(read_file(default_presets_file()), read_file(kPresets));
  const PresetsFile presets(kPresets);
  EXPECT_EQ(presets.names_text(), "fast, balanced, accurate");
  for (const std::string& name : presets.names()) {
    for (const char* section : {"bake", "live"}) {
      const PresetSection s = presets.section(name, section);
      EXPECT_TRUE(s.node.IsMap()) << name << "." << section;
      EXPECT_EQ(s.field_of("x"), name + "." + section + ".x");
    }
  }
}

TEST(Presets, AnUnknownNameListsTheValidOnesAndTheFile) {
  const std::string message = error_of([] { (void)PresetsFile(kPresets).section("turbo", "bake"); });
  EXPECT_NE(message.find("turbo"), std::string::npos) << message;
  EXPECT_NE(message.find(kPresets.string()), std::string::npos) << message;
  EXPECT_NE(message.find("fast, balanced, accurate"), std::string::npos) << message;
}

TEST(Presets, ABadShapeIsNamed) {
  const test::TempDir dir;
  const fs::path file = dir / "presets.yaml";
  std::ofstream(file) << "quick:\n  bake: {frequency: 2, basis: faces, samples: 4}\n";
  std::string message = error_of([&] { (void)PresetsFile{file}; });
  EXPECT_NE(message.find("quick.live"), std::string::npos) << message;
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;

  std::ofstream(file) << "quick:\n  bake: {frequency: 2}\n  live: {}\n  lives: {}\n";
  message = error_of([&] { (void)PresetsFile{file}; });
  EXPECT_NE(message.find("lives"), std::string::npos) << message;

  std::ofstream(file) << "{}\n";
  message = error_of([&] { (void)PresetsFile{file}; });
  EXPECT_NE(message.find("no presets"), std::string::npos) << message;
  fs::remove(file);
}

}  // namespace
}  // namespace skylit
