// sky.bracket: the sky source takes an exposure bracket for every sky and the sky stage merges
// it, so that an 8-bit camera's clipped sun comes back unclipped with its energy; a source that
// cannot bracket gives single frames and a flag; the setting's errors name the key.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "skylit/sky/sky_model.hpp"

namespace skylit::live_test {
namespace sky_bracket_test {  // named: the test program is one unity build

// The rig's config with its sky from the simulator: a clear midsummer noon at Nara as an 8-bit
// camera metered for the sky records it (the sun clips), and `sky_extra` lines under sky:.
std::string sky_sim_config(const Rig& rig, const std::string& sky_extra) {
  std::string text = rig.config_text();
  const std::string images = "  source:\n    kind: images\n    path: sky\n    loop: false\n";
  const std::size_t at = text.find(images);
  EXPECT_NE(at, std::string::npos) << text;
  text.replace(at, images.size(),
               "  source: {kind: sky-sim, calibration: sky.yaml, sky: clear, frames: 1, exposure_time: 0.06,\n"
               "           start: 2026-06-21T11:40:00+09:00, latitude: 34.69, longitude: 135.80}\n" + sky_extra);
  return text;
}

// The sun's luminance in /status once the first sky has come, and whether it was clipped.
struct SeenSun {
  double luminance = 0;
  bool clipped = false;
  Vector3d direction = Vector3d::UnitZ();
  nlohmann::json status;
};

SeenSun first_sun(const Rig& rig, const std::string& config_text) {
  std::ofstream(rig.config_file()) << config_text;
  live::ServiceOptions options = quiet_options();
  options.frames = 100000;
  RunningService running(rig.config(), options);
  EXPECT_TRUE(running.wait_for([](const nlohmann::json& status) { return status["sky"].contains("S"); }))
      << running.error() << "\n" << running.status().dump(2);
  SeenSun seen;
  seen.status = running.status();
  const nlohmann::json& sun = seen.status["sky"]["sun"];
  if (sun.is_object()) {
    const Vector3d energy(sun["energy"][0].get<double>(), sun["energy"][1].get<double>(), sun["energy"][2].get<double>());
    seen.luminance = sky::rgb_luminance(energy);
    seen.clipped = sun["clipped"].get<bool>();
    seen.direction = Vector3d(sun["direction"][0].get<double>(), sun["direction"][1].get<double>(),
                              sun["direction"][2].get<double>());
  }
  return seen;
}

TEST(SkyBracket, ABracketBringsAClippedSunBackWithItsEnergy) {
  const Rig rig;
  // One 8-bit frame: the sun is clipped, its pixels hold a small part of its energy.
  const SeenSun single = first_sun(rig, sky_sim_config(rig, ""));
  // Four exposures 30× apart: the shortest holds the sun's pixel unclipped.
  const SeenSun bracketed = first_sun(rig, sky_sim_config(rig, "  bracket: [0.06, 0.002, 0.00006, 0.000002]\n"));
  ASSERT_GT(bracketed.luminance, 0.0) << bracketed.status.dump(2);
  EXPECT_FALSE(bracketed.clipped);
  const double truth = sky::rgb_luminance(sky::ClearSky(bracketed.direction, 3.0).sun().irradiance);
  std::printf("sun luminance: one frame %.4g (clipped %d), bracket %.4g (clipped %d), truth %.4g\n", single.luminance,
              single.clipped, bracketed.luminance, bracketed.clipped, truth);
  EXPECT_NEAR(bracketed.luminance / truth, 1.0, 0.15);
  EXPECT_LT(single.luminance, 0.2 * truth) << "one 8-bit frame keeps only a lower bound";
  EXPECT_FALSE(bracketed.status["sky"]["bracket"]["unsupported"].get<bool>());
  EXPECT_EQ(bracketed.status["sky"]["bracket"]["exposures_s"].size(), 4u);
}

TEST(SkyBracket, ASourceThatCannotBracketGivesSingleFramesAndAFlag) {
  const Rig rig;
  std::string text = rig.config_text();
  text.insert(text.find("  stale_after:"), "  bracket: [0.01, 0.001]\n");
  std::ofstream(rig.config_file()) << text;
  live::ServiceOptions options = quiet_options();
  options.frames = 100000;
  RunningService running(rig.config(), options);
  ASSERT_TRUE(running.wait_for([](const nlohmann::json& status) { return status["sky"].contains("S"); }))
      << running.error() << "\n" << running.status().dump(2);
  const nlohmann::json status = running.status();
  EXPECT_TRUE(status["sky"]["bracket"]["unsupported"].get<bool>());
  const auto flags = status["flags"].get<std::vector<std::string>>();
  EXPECT_NE(std::find(flags.begin(), flags.end(), "sky_bracket_unsupported"), flags.end());
}

TEST(SkyBracket, BadBracketsAreRefusedNamingTheKey) {
  const Rig rig;
  for (const std::string bracket : {"[0.01]", "[0.01, 0.01]", "[0.01, -0.001]", "0.01"}) {
    std::string text = rig.config_text();
    text.insert(text.find("  stale_after:"), "  bracket: " + bracket + "\n");
    std::ofstream(rig.config_file()) << text;
    const std::string message = skylit::test::error_of([&] { live::load_live_config(rig.config_file()); });
    EXPECT_NE(message.find("sky.bracket"), std::string::npos) << bracket << ": " << message;
  }
}

}  // namespace sky_bracket_test
}  // namespace skylit::live_test
