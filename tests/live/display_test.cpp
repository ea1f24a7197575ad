// The HMD display in skylit-live: the `display:` section of the config, and the service run
// under Xvfb with a stereo side-by-side profile (its recording keeps the undistorted composite),
// and an unknown monitor refused with the monitors present.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "../cli/cli_support.hpp"
#include "../support/virtual_display.hpp"
#include "live_fixture.hpp"
#include "skylit/base/error.hpp"

namespace skylit::live_test {
namespace {

// A small side-by-side HMD (fits Xvfb's screen), with lenses.
void write_small_hmd(const fs::path& file) {
  std::ofstream(file) << "name: small test HMD\npanel: {width: 320, height: 120}\nlayout: side-by-side\n"
                         "ipd: 0.064\nlens:\n  red: [0.20, 0.20, 0]\n  green: [0.22, 0.24, 0]\n  blue: [0.24, 0.28, 0]\n";
}

TEST(ServiceConfig, DisplaySection) {
  const Rig rig;
  const fs::path file = rig.dir() / "display.yaml";
  std::ofstream(file) << rig.config_text() << "display:\n  profile: hmd/small.yaml\n  monitor: HDMI-1\n  mode: stereo\n";
  live::LiveConfig config = live::load_live_config(file);
  ASSERT_TRUE(config.display.has_value());
  EXPECT_EQ(config.display->profile, rig.dir() / "hmd" / "small.yaml");  // relative to the config
  EXPECT_EQ(config.display->monitor, "HDMI-1");
  EXPECT_TRUE(config.display->stereo);

  std::ofstream(file) << rig.config_text() << "display: {profile: hmd.yaml}\n";
  config = live::load_live_config(file);
  ASSERT_TRUE(config.display.has_value());
  EXPECT_FALSE(config.display->stereo);   // mono by default
  EXPECT_TRUE(config.display->monitor.empty());
  EXPECT_FALSE(live::load_live_config(rig.config_file()).display.has_value());

  std::ofstream(file) << rig.config_text() << "display: {profile: hmd.yaml, mode: 3d}\n";
  try {
    (void)live::load_live_config(file);
    FAIL() << "mode 3d accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("display.mode"), std::string::npos) << message;
    EXPECT_NE(message.find("stereo"), std::string::npos) << message;
  }
}

TEST(SkylitLive, AStereoHmdDisplayUnderXvfbAndItsRecording) {
  const gpu::test::VirtualDisplay xvfb("320x240x24");
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  RigOptions options;
  options.extra = "display:\n  profile: small_hmd.yaml\n  mode: stereo\n";
  const Rig rig(options);
  write_small_hmd(rig.dir() / "small_hmd.yaml");
  const fs::path video = rig.dir() / "live.avi";
  const cli_test::Result result = cli_test::run_program(
      cli_test::kBin / "skylit-live", rig.config_file().string() + " --frames 6 --record " + video.string());
  ASSERT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find("in a window"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("6 frames composited"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("HMD display 'small test HMD': stereo (a render per eye), 320×120 panel"),
            std::string::npos) << result.output;
  // The recording is the undistorted composite, the camera's size.
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  cv::Mat frame;
  ASSERT_TRUE(capture.read(frame));
  EXPECT_EQ(frame.size(), cv::Size(96, 72));
}

TEST(SkylitLive, AnUnknownMonitorIsRefusedWithTheMonitorsPresent) {
  const gpu::test::VirtualDisplay xvfb("320x240x24");
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  RigOptions options;
  options.extra = "display:\n  profile: small_hmd.yaml\n  monitor: No Such HMD\n";
  const Rig rig(options);
  write_small_hmd(rig.dir() / "small_hmd.yaml");
  const cli_test::Result result = cli_test::run_program(cli_test::kBin / "skylit-live", rig.config_file().string() + " --frames 2");
  EXPECT_EQ(result.status, 2) << result.output;
  EXPECT_NE(result.output.find("no monitor named 'No Such HMD'; monitors present: 'screen'"), std::string::npos)
      << result.output;
}

}  // namespace
}  // namespace skylit::live_test
