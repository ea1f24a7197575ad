// camera.stereo in skylit-live: a pair of cameras (a `pair` source of two image sequences) as one
// side-by-side frame, the stereo calibration from skylit-calib stereo; /status shows the pairing
// and the stereo camera; a frame that is not the two cameras side by side is an error /status
// names; under Xvfb with a stereo HMD each eye is composited from its own camera.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

#include "../cli/cli_support.hpp"
#include "../support/virtual_display.hpp"
#include "live_fixture.hpp"
#include "skylit/camera/stereo_calibration.hpp"
#include "skylit/sky/srgb.hpp"

namespace skylit::live_test {
namespace stereo_camera_test {  // named: the test program is one unity build

// The rig with a stereo camera: the rig's HMD camera twice, 64 mm apart, its frames from two
// image folders (left/, right/) paired by timestamp; `camera_extra` appended to camera.source.
std::string stereo_config(const Rig& rig, int frames, const std::string& right_frames_extra = "") {
  camera::StereoCalibration stereo;
  stereo.left = camera::load_calibration(rig.dir() / "hmd.yaml");
  stereo.right = stereo.left;
  stereo.t_right_from_left = Vector3d(-0.064, 0, 0);
  camera::save_stereo_calibration(stereo, rig.dir() / "stereo.yaml");
  std::vector<cv::Mat> left, right;
  for (int k = 0; k < frames; ++k) {
    left.push_back(camera_frame(96, 72, k));
    right.push_back(camera_frame(96, 72, k + 1));  // another view: the checker's phase moved
  }
  write_frames(rig.dir() / "left", left, 30.0, "png");
  write_frames(rig.dir() / "right", right, 30.0, "png");
  std::string text = rig.config_text();
  const std::size_t from = text.find("camera:\n");
  const std::size_t to = text.find("pose:", from);
  text.replace(from, to - from,
               "camera:\n  stereo: stereo.yaml\n  source:\n    kind: pair\n    tolerance_ms: 5\n"
               "    left: {kind: images, path: left, loop: true, realtime: 1}\n"
               "    right: {kind: images, path: right, loop: true, realtime: 1" + right_frames_extra + "}\n");
  return text;
}

TEST(LiveStereoCamera, APairOfCamerasRunsAsOneStereoCamera) {
  const Rig rig;
  std::ofstream(rig.config_file()) << stereo_config(rig, 3);
  const live::LiveConfig config = rig.config();
  EXPECT_EQ(config.camera.stereo, rig.dir() / "stereo.yaml");
  EXPECT_TRUE(config.camera.calibration.empty());
  live::ServiceOptions options = quiet_options();
  options.frames = 8;
  RunningService running(config, options);
  running.join();
  ASSERT_EQ(running.error(), "");
  const nlohmann::json status = running.status();
  const nlohmann::json& camera_json = status["camera"];
  ASSERT_TRUE(camera_json.contains("pair")) << camera_json.dump(2);
  EXPECT_GE(camera_json["pair"]["paired"].get<std::int64_t>(), 8);
  EXPECT_EQ(camera_json["pair"]["unpaired_left"].get<std::int64_t>(), 0);
  EXPECT_EQ(camera_json["pair"]["unpaired_right"].get<std::int64_t>(), 0);
  EXPECT_DOUBLE_EQ(camera_json["pair"]["tolerance_ms"].get<double>(), 5.0);
  EXPECT_NEAR(camera_json["stereo"]["baseline_m"].get<double>(), 0.064, 1e-12);
  EXPECT_EQ(camera_json["errors"].get<std::int64_t>(), 0);
  EXPECT_TRUE(camera_json["last_frame_error"].is_null());
  EXPECT_EQ(status["frames"].get<std::int64_t>(), 8);
}

TEST(LiveStereoCamera, AFrameThatIsNotTheTwoCamerasSideBySideIsAnErrorTheStatusNames) {
  const Rig rig;
  std::string text = stereo_config(rig, 3);
  // One camera's frames under a stereo calibration: half the width it needs.
  text.replace(text.find("  source:\n    kind: pair"), text.find("pose:") - text.find("  source:\n    kind: pair"),
               "  source: {kind: images, path: left, loop: true, realtime: 1}\n");
  std::ofstream(rig.config_file()) << text;
  live::ServiceOptions options = quiet_options();
  options.frames = 100000;
  RunningService running(rig.config(), options);
  ASSERT_TRUE(running.wait_for([](const nlohmann::json& status) { return status["camera"]["errors"].get<std::int64_t>() > 0; }))
      << running.status().dump(2);
  const std::string error = running.status()["camera"]["last_frame_error"].get<std::string>();
  EXPECT_NE(error.find("camera.stereo"), std::string::npos) << error;
  EXPECT_NE(error.find("96×72 is not the two cameras side by side"), std::string::npos) << error;
}

TEST(ServiceConfig, OneCameraOrAStereoCameraNotBoth) {
  const Rig rig;
  std::string text = stereo_config(rig, 1);
  text.insert(text.find("  stereo: stereo.yaml"), "  calibration: hmd.yaml\n");
  std::ofstream(rig.config_file()) << text;
  const std::string message = skylit::test::error_of([&] { live::load_live_config(rig.config_file()); });
  EXPECT_NE(message.find("camera.stereo"), std::string::npos) << message;
  EXPECT_NE(message.find("both calibration and stereo"), std::string::npos) << message;
}

TEST(SkylitLive, AStereoCameraOnAStereoHmdUnderXvfb) {
  const gpu::test::VirtualDisplay xvfb("320x240x24");
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  RigOptions rig_options;
  rig_options.extra = "display:\n  profile: small_hmd.yaml\n  mode: stereo\n";
  const Rig rig(rig_options);
  std::ofstream(rig.dir() / "small_hmd.yaml") << "name: small test HMD\npanel: {width: 320, height: 120}\n"
                                                 "layout: side-by-side\nipd: 0.064\n";
  std::ofstream(rig.config_file()) << stereo_config(rig, 3);
  const fs::path video = rig.dir() / "live.avi";
  const cli_test::Result result = cli_test::run_program(
      cli_test::kBin / "skylit-live", rig.config_file().string() + " --frames 6 --record " + video.string());
  ASSERT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find("stereo (a render per eye, a camera per eye), 320×120 panel"), std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("6 frames composited"), std::string::npos) << result.output;
  // The recording is the left camera's composite, at its size.
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  cv::Mat frame;
  ASSERT_TRUE(capture.read(frame));
  EXPECT_EQ(frame.size(), cv::Size(96, 72));
}

// In stereo display each eye takes its own camera's photometric match: the right camera's frames
// at half the left's linear values give half its k.
TEST(LiveStereoCamera, EachCameraHasItsOwnPhotometricMatch) {
  const gpu::test::VirtualDisplay xvfb("320x240x24");
  if (xvfb.display().empty()) GTEST_SKIP() << "Xvfb is not installed (apt install xvfb)";
  const gpu::test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const gpu::test::ScopedEnv wayland("WAYLAND_DISPLAY", nullptr);
  RigOptions rig_options;
  rig_options.extra = "display:\n  profile: small_hmd.yaml\n  mode: stereo\nphotometric:\n  estimate:\n"
                      "    plane: ground\n    region: [0, 0.25, 0, 0.25]\n    every: 1\n";
  const Rig rig(rig_options);
  std::ofstream(rig.dir() / "small_hmd.yaml") << "name: small test HMD\npanel: {width: 320, height: 120}\n"
                                                 "layout: side-by-side\nipd: 0.064\n";
  const std::string text = stereo_config(rig, 3);
  // The right camera's frames: the same view (the checker's phase as the left's), every linear
  // value halved.
  std::vector<cv::Mat> right;
  for (int k = 0; k < 3; ++k) {
    cv::Mat frame = camera_frame(96, 72, k);
    frame.forEach<cv::Vec3b>([](cv::Vec3b& p, const int*) {
      for (int c = 0; c < 3; ++c) p[c] = sky::srgb_encode8(0.5 * sky::srgb_decode(p[c] / 255.0));
    });
    right.push_back(frame);
  }
  write_frames(rig.dir() / "right", right, 30.0, "png");
  std::ofstream(rig.config_file()) << text;
  live::ServiceOptions options = quiet_options();
  options.headless = false;
  options.frames = 100000;
  RunningService running(rig.config(), options);
  ASSERT_TRUE(running.wait_for([](const nlohmann::json& status) { return status.contains("photometric_scale_right"); }))
      << running.error() << "\n" << running.status().dump(2);
  const nlohmann::json status = running.status();
  for (int c = 0; c < 3; ++c) {
    const double ratio = status["photometric_scale_right"][c].get<double>() / status["photometric_scale"][c].get<double>();
    EXPECT_NEAR(ratio, 0.5, 0.03) << "channel " << c;  // 8-bit rounding of the halved codes
  }
}

}  // namespace stereo_camera_test
}  // namespace skylit::live_test
