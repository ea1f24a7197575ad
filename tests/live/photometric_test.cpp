// photometric.estimate: the match k is first estimated on the first frame that has a sky (before
// it the building is not drawn; a configured k would show it far too bright or dark until the
// next estimate), then every `every` frames, the last estimate holding in between.
#include <cmath>

#include <gtest/gtest.h>

#include "live_fixture.hpp"

namespace skylit::live_test {
namespace {

// A corner of the ground far from the building (nothing virtual hides or shades it).
constexpr const char* kEstimate = "photometric:\n  estimate:\n    plane: ground\n    region: [0, 0.25, 0, 0.25]\n";

TEST(LivePhotometric, TheFirstEstimateComesWithTheFirstSky) {
  RigOptions rig_options;
  // Far more frames between estimates than the run has: only the first-sky rule can give one.
  rig_options.extra = std::string(kEstimate) + "    every: 1000000\n";
  const Rig rig(rig_options);
  live::ServiceOptions options = quiet_options();
  // Three seconds of 30 frames/s: the first sky comes well within them, even on a loaded machine
  // (12 frames, 0.4 s, once ended before it).
  options.frames = 90;
  RunningService running(rig.config(), options);
  running.join();
  ASSERT_EQ(running.error(), "");
  const nlohmann::json status = running.status();
  ASSERT_LT(status["frames_without_sky"].get<std::int64_t>(), 90) << "no frame had a sky";
  ASSERT_TRUE(status.contains("photometric_scale")) << status.dump(2);
  const nlohmann::json& k = status["photometric_scale"];
  ASSERT_EQ(k.size(), 3u);
  for (const auto& channel : k) {
    EXPECT_TRUE(std::isfinite(channel.get<double>()));
    EXPECT_GT(channel.get<double>(), 0.0);
  }
}

TEST(LivePhotometric, WithoutAnEstimateTheScaleIsTheConfiguredOne) {
  RigOptions rig_options;
  rig_options.extra = "photometric:\n  scale: [0.5, 0.6, 0.7]\n";
  const Rig rig(rig_options);
  live::ServiceOptions options = quiet_options();
  options.frames = 6;
  RunningService running(rig.config(), options);
  running.join();
  ASSERT_EQ(running.error(), "");
  EXPECT_FALSE(running.status().contains("photometric_scale")) << "an estimate without photometric.estimate";
}

}  // namespace
}  // namespace skylit::live_test
