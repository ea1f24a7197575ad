// The service before its first sky (the camera image alone, "waiting for sky" in the status), and
// the frame rate of its recordings (the HMD camera's, or record.fps).
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "../support/quiet_bake.hpp"
#include "live_fixture.hpp"
#include "skylit/bake_format/light_map.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::live_test {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

std::string read_bytes(const fs::path& file) {
  std::ostringstream out;
  out << std::ifstream(file, std::ios::binary).rdbuf();
  return out.str();
}

// The frame log beside a recording: per line, whether the frame had a sky.
std::vector<bool> frames_with_sky(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header: frame,file,timestamp,sky_timestamp,...
  std::vector<bool> with_sky;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    with_sky.push_back(fields.size() > 3 && !fields[3].empty());
  }
  return with_sky;
}

TEST(ServiceStartup, BeforeTheFirstSkyTheCameraImageIsShownAlone) {
  RigOptions rig_options;
  rig_options.sky_loop = true;  // the sky folder is read again and again until its frame can be read
  rig_options.sky_realtime = "1";  // (once a second once it can)
  const Rig rig(rig_options);
  // The sky frame is not readable yet (a file still being copied): no sky for a while.
  const fs::path sky_file = rig.dir() / "sky" / "frame_0000.exr";
  const std::string sky_bytes = read_bytes(sky_file);
  std::ofstream(sky_file, std::ios::binary | std::ios::trunc) << sky_bytes.substr(0, 64);

  live::ServiceOptions options = quiet_options();
  options.record = rig.dir() / "recorded";
  RunningService running(rig.config(), options);
  ASSERT_TRUE(running.wait_for([](const json& s) { return frames_of(s) >= 6; })) << running.error();
  const json waiting = running.status();
  EXPECT_EQ(waiting["state"], "waiting for sky") << waiting.dump(2);
  EXPECT_EQ(waiting["sky"]["estimates"], 0);
  EXPECT_GT(waiting["sky"]["malformed"].get<int>(), 0);  // the cut file, tried on every pass
  EXPECT_NE(running.service().metrics_text().find("skylit_waiting_for_sky 1\n"), std::string::npos);

  // The file is complete: the sky comes, and with it the building and its shadows.
  {
    const fs::path part = rig.dir() / "frame_0000.exr.part";
    std::ofstream(part, std::ios::binary) << sky_bytes;
    fs::rename(part, sky_file);
  }
  ASSERT_TRUE(running.wait_for([](const json& s) { return s["sky"]["estimates"].get<int>() >= 1; }, 30))
      << running.status().dump(2);
  const std::int64_t frames_at_sky = frames_of(running.status());
  ASSERT_TRUE(running.wait_for([&](const json& s) { return frames_of(s) >= frames_at_sky + 6; }, 30));
  EXPECT_EQ(running.status()["state"], "running");
  EXPECT_NE(running.service().metrics_text().find("skylit_waiting_for_sky 0\n"), std::string::npos);
  running.finish();
  ASSERT_TRUE(running.error().empty()) << running.error();

  // Each recorded frame: without a sky, exactly one of the camera's frames; with one, the building
  // changes a large part of the image.
  const std::vector<bool> with_sky = frames_with_sky(rig.dir() / "recorded" / "frames.csv");
  int before = 0, after = 0, smallest_change = 255 * 3;
  for (std::size_t k = 0; k < with_sky.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06zu.png", k);
    const cv::Mat frame = cv::imread((rig.dir() / "recorded" / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(frame.empty()) << name;
    int nearest = 255;
    int changed_pixels = frame.rows * frame.cols;
    for (const cv::Mat& input : rig.camera_frames()) {
      nearest = std::min(nearest, max_difference(frame, input));
      cv::Mat difference, grey;
      cv::absdiff(frame, input, difference);
      cv::cvtColor(difference, grey, cv::COLOR_BGR2GRAY);
      changed_pixels = std::min(changed_pixels, cv::countNonZero(grey > 10));
    }
    if (!with_sky[k]) {
      ++before;
      EXPECT_EQ(nearest, 0) << name << " was composited before the sky: the camera image alone";
      EXPECT_EQ(after, 0) << name << ": a frame without a sky after one with it";
    } else {
      ++after;
      smallest_change = std::min(smallest_change, changed_pixels);
    }
  }
  std::printf("measured: %d frames before the sky (the camera image, exactly), %d after it (building and shadows: "
              "≥ %d of %d pixels changed by more than 10 codes)\n",
              before, after, smallest_change, rig.camera_frames()[0].rows * rig.camera_frames()[0].cols);
  EXPECT_GE(before, 6);
  EXPECT_GE(after, 6);
  EXPECT_GT(smallest_change, rig.camera_frames()[0].rows * rig.camera_frames()[0].cols / 20);
}

// Runs the rig's camera (frames at `camera_fps`, each once) into a video; the video's rate as
// OpenCV reads it back, and the service's status.
struct RecordedVideo {
  double fps = 0;
  int frames = 0;         // read back from the video
  int logged_frames = 0;  // lines of its frame log
  json status;
  std::string error;
};
RecordedVideo record_video(double camera_fps, const std::string& extra) {
  RigOptions rig_options;
  rig_options.camera_fps = camera_fps;
  rig_options.camera_frames = 12;
  rig_options.camera_loop = false;
  rig_options.camera_realtime = "4";  // 4× the filmed pace: the rate comes from the timestamps
  rig_options.extra = extra;
  const Rig rig(rig_options);
  live::ServiceOptions options = quiet_options();
  options.record = rig.dir() / "live.mp4";
  RecordedVideo out;
  {
    RunningService running(rig.config(), options);
    running.join();  // the camera's frames end
    out.error = running.error();
    out.status = running.status();
  }
  cv::VideoCapture video((rig.dir() / "live.mp4").string());
  if (!video.isOpened()) {
    out.error += " cannot read the recording back";
    return out;
  }
  out.fps = video.get(cv::CAP_PROP_FPS);
  for (cv::Mat frame; video.read(frame);) ++out.frames;
  out.logged_frames = static_cast<int>(frames_with_sky(rig.dir() / "live.csv").size());
  return out;
}

TEST(ServiceRecording, AVideoIsWrittenAtTheCameraFrameRate) {
  for (const double camera_fps : {12.0, 25.0}) {
    SCOPED_TRACE(camera_fps);
    const RecordedVideo video = record_video(camera_fps, "");
    ASSERT_TRUE(video.error.empty()) << video.error;
    std::printf("measured: camera at %.0f frames/s (played 4× faster): the video at %.3f frames/s, %d frames "
                "(%d composited, %d logged)\n",
                camera_fps, video.fps, video.frames, video.status["frames"].get<int>(), video.logged_frames);
    EXPECT_NEAR(video.fps, camera_fps, 0.01 * camera_fps);
    // The frames.csv timestamps have 6 decimals: the measured rate is that close.
    EXPECT_NEAR(video.status["record_fps"].get<double>(), camera_fps, 1e-4 * camera_fps);
    EXPECT_NEAR(video.status["camera"]["frame_rate_hz"].get<double>(), camera_fps, 1e-4 * camera_fps);
    EXPECT_EQ(video.logged_frames, video.status["frames"].get<int>());
    EXPECT_EQ(video.frames, video.logged_frames);
  }
}

TEST(ServiceRecording, RecordFpsSetsTheVideoRate) {
  const RecordedVideo video = record_video(12.0, "output:\n  record: {fps: 5}\n");
  ASSERT_TRUE(video.error.empty()) << video.error;
  EXPECT_NEAR(video.fps, 5.0, 0.05);
  EXPECT_DOUBLE_EQ(video.status["record_fps"].get<double>(), 5.0);
  EXPECT_EQ(video.frames, video.logged_frames);
}

TEST(ServiceConfig, BlendDeviceAndRecordSettings) {
  const Rig rig;
  const fs::path file = rig.dir() / "settings.yaml";
  std::ofstream(file) << rig.config_text() << "blend: cpu\noutput:\n  record: {path: out/live.mp4, fps: 12.5}\n";
  live::LiveConfig config = live::load_live_config(file);
  EXPECT_EQ(config.blend.device, live::BlendDevice::Cpu);
  EXPECT_EQ(config.output.record, rig.dir() / "out" / "live.mp4");
  ASSERT_TRUE(config.output.record_fps.has_value());
  EXPECT_DOUBLE_EQ(*config.output.record_fps, 12.5);

  std::ofstream(file) << rig.config_text() << "blend:\n  device: gpu\n  threads: 3\n  storage: unorm8\noutput:\n  record: a.avi\n";
  config = live::load_live_config(file);
  EXPECT_EQ(config.blend.device, live::BlendDevice::Gpu);
  EXPECT_EQ(config.blend.threads, 3);
  EXPECT_EQ(config.blend.storage, blend::BasisStorage::Unorm8);
  EXPECT_EQ(config.output.record, rig.dir() / "a.avi");
  EXPECT_FALSE(config.output.record_fps.has_value());

  std::ofstream(file) << rig.config_text();
  EXPECT_EQ(live::load_live_config(file).blend.device, live::BlendDevice::Auto);
  EXPECT_EQ(live::load_live_config(file).render.scale, 1.0);

  // EAC blocks and the building's render scale.
  std::ofstream(file) << rig.config_text() << "blend:\n  device: gpu\n  storage: eac\nrender:\n  scale: 0.75\n";
  config = live::load_live_config(file);
  EXPECT_EQ(config.blend.storage, blend::BasisStorage::Eac11);
  EXPECT_DOUBLE_EQ(config.render.scale, 0.75);
  std::ofstream(file) << rig.config_text() << "render:\n  scale: 1.5\n";
  try {
    live::load_live_config(file);
    ADD_FAILURE() << "a render scale over 1 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("render.scale"), std::string::npos) << e.what();
  }
  std::ofstream(file) << rig.config_text() << "blend:\n  storage: eac\n  basis: pca\n";
  try {
    live::load_live_config(file);
    ADD_FAILURE() << "eac with the PCA form was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("blend.storage"), std::string::npos) << e.what();
  }
}

TEST(ServiceConfig, MaxSourcesIsASettingWithinTheGpuBlendsLimit) {
  RigOptions options;
  EXPECT_EQ(live::load_live_config(Rig(options).config_file()).sky.max_sources, 1);
  options.max_sources = 16;
  EXPECT_EQ(live::load_live_config(Rig(options).config_file()).sky.max_sources, 16);
  for (const int bad : {0, 33}) {
    options.max_sources = bad > 1 ? bad : 1;
    const Rig rig(options);
    const fs::path file = rig.dir() / "bad_sources.yaml";
    std::string text = rig.config_text();
    if (bad <= 1) text.insert(text.find("  stale_after:"), "  max_sources: 0\n");
    std::ofstream(file) << text;
    const std::string message = skylit::test::error_of([&] { live::load_live_config(file); });
    EXPECT_NE(message.find("field 'sky.max_sources'"), std::string::npos) << message;
    EXPECT_NE(message.find("32"), std::string::npos) << message;
  }
}

// sky.sun_colour: daylight (the default) corrects a sun whose colour is impossible; measured keeps it.
TEST(ServiceConfig, TheSunsColourIsASetting) {
  const Rig rig;
  const fs::path file = rig.dir() / "sun_colour.yaml";
  std::ofstream(file) << rig.config_text();
  EXPECT_TRUE(live::load_live_config(file).sky.correct_sun_colour);
  std::string text = rig.config_text();
  text.insert(text.find("  stale_after:"), "  sun_colour: measured\n");
  std::ofstream(file) << text;
  EXPECT_FALSE(live::load_live_config(file).sky.correct_sun_colour);
  text.replace(text.find("sun_colour: measured"), 20, "sun_colour: sepia");
  std::ofstream(file) << text;
  const std::string message = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(message.find("sky.sun_colour"), std::string::npos) << message;
  EXPECT_NE(message.find("daylight"), std::string::npos) << message;
}

// How a clipped sun's energy is found (sky.clipped_sun_energy): measured unless the config says
// clear_sky; anything else is refused, naming the key and the choices.
TEST(ServiceConfig, AClippedSunsEnergyIsASetting) {
  const Rig rig;
  const fs::path file = rig.dir() / "clipped_sun.yaml";
  std::ofstream(file) << rig.config_text();
  EXPECT_EQ(live::load_live_config(file).sky.clipped_sun_energy, sky::ClippedSunEnergy::Measured);
  std::string text = rig.config_text();
  text.insert(text.find("  stale_after:"), "  clipped_sun_energy: clear_sky\n");
  std::ofstream(file) << text;
  EXPECT_EQ(live::load_live_config(file).sky.clipped_sun_energy, sky::ClippedSunEnergy::ClearSky);
  EXPECT_NO_THROW(live::Service(live::load_live_config(file), quiet_options()));
  text.replace(text.find("clipped_sun_energy: clear_sky"), 29, "clipped_sun_energy: guess");
  std::ofstream(file) << text;
  const std::string message = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(message.find("sky.clipped_sun_energy"), std::string::npos) << message;
  EXPECT_NE(message.find("clear_sky"), std::string::npos) << message;
  // shadow_contrast needs ground in a real shadow on the photometric region's plane.
  text.replace(text.find("clipped_sun_energy: guess"), 25, "clipped_sun_energy: shadow_contrast");
  std::ofstream(file) << text;
  const std::string without = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(without.find("sky.clipped_sun_energy"), std::string::npos) << without;
  EXPECT_NE(without.find("photometric.estimate.shadowed_region"), std::string::npos) << without;
  std::ofstream(file) << text << "photometric:\n  estimate:\n    plane: ground\n    region: [0, 0.25, 0, 0.25]\n"
                      << "    shadowed_region: [0.3, 0.5, 0, 0.25]\n    shadowed_sky_visibility: 0.9\n";
  const live::LiveConfig config = live::load_live_config(file);
  EXPECT_EQ(config.sky.clipped_sun_energy, sky::ClippedSunEnergy::ShadowContrast);
  ASSERT_TRUE(config.photometric.shadowed_region);
  EXPECT_DOUBLE_EQ((*config.photometric.shadowed_region)[1], 0.5);
  EXPECT_DOUBLE_EQ(config.photometric.shadowed_sky_visibility, 0.9);
  std::ofstream(file) << text << "photometric:\n  estimate:\n    plane: ground\n"
                      << "    shadowed_region: [0.3, 0.5, 0, 0.25]\n    shadowed_sky_visibility: 1.5\n";
  const std::string above = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(above.find("photometric.estimate.shadowed_sky_visibility"), std::string::npos) << above;
}

// The ground's light on the building (render.ground_light, render.ground_albedo): a setting of
// the config and the presets; a bake without the ground layer is refused at start, naming it.
TEST(ServiceConfig, TheGroundsLightIsASettingThatNeedsTheBakesGroundLayer) {
  const Rig rig;
  const fs::path file = rig.dir() / "ground.yaml";
  std::ofstream(file) << rig.config_text();
  live::LiveConfig config = live::load_live_config(file);
  EXPECT_FALSE(config.render.ground_light);
  EXPECT_FALSE(config.render.ground_albedo.has_value());
  std::ofstream(file) << rig.config_text() << "render:\n  ground_light: true\n  ground_albedo: [0.1, 0.2, 0.3]\n";
  config = live::load_live_config(file);
  EXPECT_TRUE(config.render.ground_light);
  ASSERT_TRUE(config.render.ground_albedo.has_value());
  EXPECT_EQ(*config.render.ground_albedo, Eigen::Vector3d(0.1, 0.2, 0.3));
  std::ofstream(file) << rig.config_text() << "render:\n  ground_light: true\n  ground_albedo: 0.25\n";
  EXPECT_EQ(*live::load_live_config(file).render.ground_albedo, Eigen::Vector3d::Constant(0.25));
  EXPECT_NO_THROW(live::Service(live::load_live_config(file), quiet_options()));
  for (const char* bad : {"1.5", "[0.2, 0.2]", "bright"}) {
    std::ofstream(file) << rig.config_text() << "render:\n  ground_albedo: " << bad << "\n";
    const std::string message = skylit::test::error_of([&] { live::load_live_config(file); });
    EXPECT_NE(message.find("render.ground_albedo"), std::string::npos) << bad << ": " << message;
  }
  // A bake made with --ground-samples 0: its manifest without the layer.
  const BakedSite& baked = BakedSite::get();
  const fs::path bare = rig.dir() / "bare_bake";
  fs::copy(baked.dir / "bake", bare, fs::copy_options::recursive);
  nlohmann::json manifest = nlohmann::json::parse(read_file(bare / "manifest.json"));
  ASSERT_TRUE(manifest.contains("ground"));
  manifest.erase("ground");
  manifest["plan"].erase("ground_samples");
  write_file_atomic(bare / "manifest.json", manifest.dump(2));
  std::string text = rig.config_text();
  const std::string bake_line = "bake: " + quoted(baked.dir / "bake");
  text.replace(text.find(bake_line), bake_line.size(), "bake: " + quoted(bare));
  std::ofstream(file) << text << "render:\n  ground_light: true\n";
  const std::string message = skylit::test::error_of([&] { live::Service(live::load_live_config(file), quiet_options()); });
  EXPECT_NE(message.find("render.ground_light"), std::string::npos) << message;
  EXPECT_NE(message.find("--ground-samples"), std::string::npos) << message;
}

// A bake that refined the model (skylit-bake --refine) with a light map (--light-map): the service
// draws and lights the refined model, whose vertices the bake's arrays follow, and its charts from
// the light map, frames with the sky composited.
TEST(ServiceConfig, ABakeOfARefinedModelWithALightMapRunsOnTheRefinedModel) {
  const Rig rig;
  const BakedSite& baked = BakedSite::get();
  const fs::path refined = rig.dir() / "refined_bake";
  skylit::test::quiet_bake(baked.dir / "site.yaml", refined, 4, [](skylit::baker::BakeOptions& o) {
    o.refine.tolerance = 0.05;
    o.ground_samples = 16;
    o.light_map = skylit::baker::LightMapOptions{0.25, 1.0, 0};
  });
  const skylit::bake_format::Manifest manifest = skylit::bake_format::read_manifest(refined);
  ASSERT_TRUE(manifest.refinement.has_value());
  ASSERT_TRUE(manifest.light_map.has_value());
  ASSERT_GT(manifest.plan.vertex_count, baked.mesh.vertex_count()) << "the tower's faces split where the annex shades them";
  std::string text = rig.config_text();
  const std::string bake_line = "bake: " + quoted(baked.dir / "bake");
  text.replace(text.find(bake_line), bake_line.size(), "bake: " + quoted(refined));
  const fs::path file = rig.dir() / "refined.yaml";
  std::ofstream(file) << text << "render:\n  ground_light: true\n";
  live::ServiceOptions options = quiet_options();
  options.frames_with_sky = 2;
  {
    live::Service service(live::load_live_config(file), options);
    EXPECT_GE(service.run(), 2);
    // The building's light is summed on the sky thread, once per sky, and the frames take it.
    const nlohmann::json status = nlohmann::json::parse(service.status_json());
    EXPECT_GT(status["stage_ms_p50"]["building_light"].get<double>(), 0.0) << status["stage_ms_p50"].dump();
    EXPECT_GE(status["building_light_sums"]["sky_thread"].get<std::int64_t>(), 1) << status["building_light_sums"].dump();
    EXPECT_EQ(status["building_light_sums"]["in_frame"].get<std::int64_t>(), 0) << status["building_light_sums"].dump();
  }
  // Its PCA form: asked for before the bake has one, refused with the fix; then added and drawn.
  std::ofstream(file) << text << "render:\n  ground_light: true\n  light_map_form: pca\n";
  const std::string message = skylit::test::error_of([&] { live::Service(live::load_live_config(file), quiet_options()); });
  EXPECT_NE(message.find("render.light_map_form"), std::string::npos) << message;
  EXPECT_NE(message.find("--light-map-components"), std::string::npos) << message;
  // Added without the full form (compress --light-map-pca-only): drawn from the PCA form, here
  // held in half floats, and the full form asked for is refused with the fix.
  skylit::baker::compress_bake(refined, std::nullopt, skylit::bake_format::LightMapPcaOptions{8, 45.0, false}, nullptr);
  std::ofstream(file) << text << "render:\n  ground_light: true\n  light_map_form: pca\n  light_map_precision: half\n";
  {
    live::Service service(live::load_live_config(file), options);
    EXPECT_GE(service.run(), 2);
    const nlohmann::json status = nlohmann::json::parse(service.status_json());
    EXPECT_EQ(status["light_map"]["precision"], "half") << status["light_map"].dump();
    // The PCA form's weights and vectors of the sky and the ground, two bytes each.
    const skylit::bake_format::Manifest compressed = skylit::bake_format::read_manifest(refined);
    const skylit::bake_format::LightMapArrays pca =
        skylit::bake_format::read_light_map(refined, compressed, skylit::bake_format::LightMapForm::Pca);
    ASSERT_TRUE(pca.pca.has_value());
    const std::size_t values = pca.pca->sky.weights.size() + pca.pca->sky.vectors.size() + pca.pca->ground.weights.size() +
                               pca.pca->ground.vectors.size();
    EXPECT_EQ(status["light_map"]["bytes"].get<std::int64_t>(), static_cast<std::int64_t>(2 * values)) << status["light_map"].dump();
    EXPECT_NE(service.metrics_text().find("skylit_light_map_bytes "), std::string::npos);
  }
  std::ofstream(file) << text << "render:\n  ground_light: true\n  light_map_form: full\n";
  const std::string full = skylit::test::error_of([&] { live::Service(live::load_live_config(file), quiet_options()); });
  EXPECT_NE(full.find("render.light_map_form"), std::string::npos) << full;
  EXPECT_NE(full.find("--light-map-pca-only"), std::string::npos) << full;
}

// Every input a config names lies inside its root (its folder, or `root:`); secrets and outputs
// may lie anywhere. The root is judged by names: a link inside it may point anywhere.
TEST(ServiceConfig, EveryInputItNamesLiesInsideItsRoot) {
  const Rig rig;
  const BakedSite& baked = BakedSite::get();
  const fs::path file = rig.dir() / "rooted.yaml";
  std::string text = rig.config_text();
  ASSERT_EQ(text.rfind("root: /\n", 0), 0u);
  text.erase(0, std::string("root: /\n").size());
  // Without a root, the config's folder: the suite's baked site lies elsewhere.
  std::ofstream(file) << text;
  std::string message = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(message.find("field 'site': '"), std::string::npos) << message;
  EXPECT_NE(message.find("is outside the folder this file may name files in, '" + rig.dir().lexically_normal().string() + "'"),
            std::string::npos) << message;
  // Through a link in the config's folder it is inside.
  fs::create_directory_symlink(baked.dir, rig.dir() / "baked");
  const auto replace = [](std::string t, const std::string& from, const std::string& to) {
    t.replace(t.find(from), from.size(), to);
    return t;
  };
  text = replace(text, "site: " + quoted(baked.dir / "site.yaml"), "site: baked/site.yaml");
  text = replace(text, "bake: " + quoted(baked.dir / "bake"), "bake: baked/bake");
  std::ofstream(file) << text;
  EXPECT_NO_THROW(live::load_live_config(file));
  std::ofstream(file) << replace(text, "  calibration: sky.yaml", "  calibration: /etc/hostname");
  message = skylit::test::error_of([&] { live::load_live_config(file); });
  EXPECT_NE(message.find("field 'sky.calibration': '/etc/hostname' is outside"), std::string::npos) << message;
  // The console's token and the recording may lie anywhere.
  std::ofstream(file) << text << "status:\n  token_file: /etc/os-release\noutput:\n  record: /var/lib/skylit/live.mp4\n";
  const live::LiveConfig config = live::load_live_config(file);
  EXPECT_EQ(config.status_access.token_file, fs::path("/etc/os-release"));
  EXPECT_EQ(config.output.record, fs::path("/var/lib/skylit/live.mp4"));
}

}  // namespace
}  // namespace skylit::live_test

namespace skylit::live_test {
namespace {

// Every file a config names is checked at start, also headless: an HMD profile with a misspelt
// key (or `ipd: 64`, millimetres for metres) is refused before the service runs, naming it.
TEST(ServiceStartup, AHeadlessServiceChecksTheHmdProfileToo) {
  const Rig rig;
  std::string profile = read_file(fs::path(SKYLIT_SOURCE_DIR) / "config/hmd/generic.yaml");
  profile.replace(profile.find("fov_deg:"), 8, "fov_dgr:");
  std::ofstream(rig.dir() / "profile.yaml") << profile;
  const fs::path file = rig.dir() / "display.yaml";
  std::ofstream(file) << rig.config_text() << "display: {profile: profile.yaml, mode: stereo}\n";
  try {
    live::Service service(live::load_live_config(file), quiet_options());  // headless
    FAIL() << "a broken HMD profile passed a headless start";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("profile.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("fov_dgr"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace skylit::live_test
