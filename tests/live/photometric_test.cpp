// photometric.estimate: the match k is first estimated on the first frame that has a sky (before
// it the building is not drawn; a configured k would show it far too bright or dark until the
// next estimate), then every `every` frames, the last estimate holding in between. With
// sky.clipped_sun_energy: shadow_contrast, a clipped sun takes the energy of the ground's shadow.
#include <cmath>

#include <gtest/gtest.h>

#include "live_fixture.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/render/compositor.hpp"
#include "skylit/sky/simulate.hpp"
#include "skylit/sky/srgb.hpp"
#include "skylit/track/pose.hpp"

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

// The sky camera is 8-bit and clips the sun; the HMD camera sees the ground of the photometric
// region lit and, beside it, in a real shadow (a quarter as bright). The sun in /status takes the
// energy that contrast gives, D_sky (r − 1) / (n·ω), and says so.
TEST(LivePhotometric, AClippedSunTakesTheEnergyOfTheGroundsRealShadow) {
  RigOptions rig_options;
  rig_options.hmd_width = 192;
  rig_options.hmd_height = 144;
  rig_options.camera_frames = 1;
  rig_options.sky_loop = true;
  rig_options.sky_realtime = "1";
  rig_options.extra = std::string(kEstimate) + "    every: 1\n    shadowed_region: [0.3, 0.5, 0, 0.25]\n";
  const Rig rig(rig_options);

  // The sky as one metered 8-bit frame (its median at 18% of full scale: the sun clips).
  const cv::Mat radiance = clear_sky_frame(rig.dir() / "sky.yaml", kSunAzimuthDeg, kSunElevationDeg);
  cv::Mat sky_pixels;
  cv::Mat green;
  cv::extractChannel(radiance, green, 1);
  cv::compare(green, 0.0, sky_pixels, cv::CMP_GT);
  fs::remove_all(rig.dir() / "sky");
  write_frames(rig.dir() / "sky", {sky::to_8bit(radiance, sky::auto_exposure_scale(radiance, sky_pixels, 0.18))}, 2.0, "png");

  // The HMD camera's frame: the ground lit at sRGB code 200, and at a quarter of that (linear)
  // where the shadowed region lies in the camera's view.
  const camera::CameraCalibration hmd = camera::load_calibration(rig.dir() / "hmd.yaml");
  render::CameraPose pose;
  pose.R_site_from_camera = track::look_at(kEye, kTarget).toRotationMatrix();
  pose.t_site_from_camera = kEye;
  cv::Mat lit_mask, shadowed_mask;
  {
    const gpu::HeadlessContext context;
    const BakedSite& baked = BakedSite::get();
    const render::Compositor compositor(baked.site, baked.mesh, baked.manifest, baked.transfer, hmd);
    lit_mask = compositor.region_mask(0, 0, 0.25, 0, 0.25, pose);
    shadowed_mask = compositor.region_mask(0, 0.3, 0.5, 0, 0.25, pose);
  }
  ASSERT_GT(cv::countNonZero(lit_mask), 200);
  ASSERT_GT(cv::countNonZero(shadowed_mask), 200);
  const double lit = sky::srgb_decode(200.0 / 255.0);
  const int shadow_code = sky::srgb_encode8(lit / 4.0);
  const double shadowed = sky::srgb_decode(shadow_code / 255.0);
  cv::Mat frame(hmd.image_height, hmd.image_width, CV_8UC3, cv::Scalar::all(200));
  frame.setTo(cv::Scalar::all(shadow_code), shadowed_mask);
  fs::remove_all(rig.dir() / "camera");
  write_frames(rig.dir() / "camera", {frame}, 30.0, "png");

  std::string text = rig.config_text();
  text.insert(text.find("  stale_after:"), "  clipped_sun_energy: shadow_contrast\n");
  std::ofstream(rig.config_file()) << text;
  live::ServiceOptions options = quiet_options();
  options.frames = 100000;
  RunningService running(rig.config(), options);
  ASSERT_TRUE(running.wait_for([](const nlohmann::json& status) {
    return status["sky"].contains("sun") && status["sky"]["sun"].is_object() &&
           status["sky"]["sun"]["energy_estimator"] == "shadow_contrast";
  })) << running.error() << "\n" << running.status().dump(2);
  const nlohmann::json status = running.status();
  const nlohmann::json& sun = status["sky"]["sun"];
  EXPECT_TRUE(sun["clipped"].get<bool>());
  const auto flags = status["flags"].get<std::vector<std::string>>();
  EXPECT_NE(std::find(flags.begin(), flags.end(), "sun_energy_estimated"), flags.end());

  // What the contrast gives, from the same sky's S and the ground plane.
  const nlohmann::json& contrast = status["shadow_contrast"];
  ASSERT_TRUE(contrast["ok"].get<bool>()) << contrast.dump(2);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_NEAR(contrast["lit"][ch].get<double>(), lit, 1e-6);
    EXPECT_NEAR(contrast["shadowed"][ch].get<double>(), shadowed, 1e-6);
  }
  std::vector<Vector3d> S;
  for (const auto& v : status["sky"]["S"]) S.emplace_back(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
  const bake_format::PlaneRecord& ground = BakedSite::get().manifest.planes[0];
  const Vector3d sky_irradiance = render::plane_irradiance(ground, S, std::nullopt);
  const Vector3d direction(sun["direction"][0].get<double>(), sun["direction"][1].get<double>(), sun["direction"][2].get<double>());
  const double sun_cos = ground.plane.normal().dot(direction.normalized());
  for (int ch = 0; ch < 3; ++ch) {
    const double expected = sky_irradiance[ch] * (lit / shadowed - 1.0) / sun_cos;
    EXPECT_NEAR(sun["energy"][ch].get<double>() / expected, 1.0, 1e-3) << "channel " << ch;
    EXPECT_NEAR(sun["energy"][ch].get<double>(), contrast["sun_energy"][ch].get<double>(), 1e-9);
  }
  EXPECT_DOUBLE_EQ(sun["energy_confidence"].get<double>(), contrast["confidence"].get<double>());
}

}  // namespace
}  // namespace skylit::live_test
