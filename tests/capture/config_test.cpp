// The `source:` node: every kind's fields, defaults, and errors that name the file, the line, the
// column and the field; the factory.
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"
#include "skylit/capture/config.hpp"
#include "skylit/sky/solar.hpp"

namespace {

using namespace skylit::capture;
using skylit::capture::testing::grey;
using skylit::capture::testing::TempDir;
namespace fs = std::filesystem;

std::string error_of(const fs::path& file) {
  try {
    load_source_config(file);
  } catch (const skylit::InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(SourceConfig, ReadsImagesWithPathsFromTheConfigsFolder) {
  TempDir dir;
  const fs::path file = dir.write("live.yaml",
                                  "other: 1\n"
                                  "source:\n"
                                  "  kind: images\n"
                                  "  name: sky\n"
                                  "  path: recordings/*.png\n"
                                  "  timestamps: recordings/t.csv\n"
                                  "  fps: 2\n"
                                  "  loop: true\n"
                                  "  width: 64\n"
                                  "  height: 48\n"
                                  "  realtime: 10\n");
  const SourceConfig config = load_source_config(file);
  EXPECT_EQ(kind_name(config), "images");
  EXPECT_EQ(config.name, "sky");
  const auto& images = std::get<ImagesSettings>(config.settings);
  EXPECT_EQ(images.path, dir.path() / "recordings/*.png");
  EXPECT_EQ(images.timestamps, dir.path() / "recordings/t.csv");
  EXPECT_EQ(images.fps, 2.0);
  EXPECT_TRUE(images.loop);
  EXPECT_EQ(config.checks.size, cv::Size(64, 48));
  EXPECT_EQ(config.realtime_speed, 10.0);
  EXPECT_FALSE(config.reconnect.has_value()) << "files are not reopened";
}

TEST(SourceConfig, CamerasReconnectByDefault) {
  TempDir dir;
  SourceConfig config = load_source_config(dir.write("a.yaml",
                                                     "source:\n  kind: v4l2\n  device: /dev/video2\n  width: 1280\n"
                                                     "  height: 720\n  fps: 30\n  fourcc: MJPG\n  bracket_settle_frames: 6\n"));
  const auto& v4l2 = std::get<V4l2Settings>(config.settings);
  EXPECT_EQ(v4l2.bracket_settle_frames, 6);
  EXPECT_EQ(v4l2.device, "/dev/video2");
  EXPECT_EQ(v4l2.width, 1280);
  EXPECT_EQ(v4l2.height, 720);
  EXPECT_EQ(v4l2.fourcc, "MJPG");
  ASSERT_TRUE(config.reconnect.has_value());
  EXPECT_DOUBLE_EQ(config.reconnect->initial_s, 0.5);
  EXPECT_DOUBLE_EQ(config.reconnect->max_s, 30.0);
  EXPECT_DOUBLE_EQ(config.reconnect->silence_s, 10.0);

  config = load_source_config(dir.write("b.yaml", "source:\n  kind: libcamera\n  camera: imx477\n"
                                                  "  pixel_format: YUYV\n  exposure_time: 0.002\n  gain: 1.5\n"
                                                  "  reconnect: {initial: 1, max: 60, stale_after: 5}\n"));
  const auto& libcamera = std::get<LibcameraSettings>(config.settings);
  EXPECT_EQ(libcamera.camera, "imx477");
  EXPECT_EQ(libcamera.pixel_format, "YUYV");
  EXPECT_EQ(libcamera.exposure_time, 0.002);
  EXPECT_EQ(libcamera.gain, 1.5);
  ASSERT_TRUE(config.reconnect.has_value());
  EXPECT_DOUBLE_EQ(config.reconnect->initial_s, 1.0);
  EXPECT_DOUBLE_EQ(config.reconnect->max_s, 60.0);
  EXPECT_DOUBLE_EQ(config.reconnect->silence_s, 10.0);
  EXPECT_DOUBLE_EQ(config.reconnect->stale_after_s, 5.0);

  config = load_source_config(dir.write("c.yaml", "source:\n  kind: v4l2\n  reconnect: false\n"));
  EXPECT_FALSE(config.reconnect.has_value());
}

TEST(SourceConfig, ReadsTheSkySimulator) {
  TempDir dir;
  const SourceConfig config = load_source_config(dir.write("sim.yaml",
                                                           "root: ..\n"  // the calibration lies beside this folder
                                                           "source:\n"
                                                           "  kind: sky-sim\n"
                                                           "  calibration: ../config/sky.yaml\n"
                                                           "  sky: clear\n"
                                                           "  start: 2026-06-21T09:00:00+09:00\n"
                                                           "  every: 10min\n"
                                                           "  frames: 12\n"
                                                           "  latitude: 34.68\n"
                                                           "  longitude: 135.84\n"
                                                           "  turbidity: 4\n"
                                                           "  exposure_time: 0.05\n"));
  const auto& sim = std::get<SkySimSettings>(config.settings);
  EXPECT_EQ(sim.calibration, (dir.path() / "../config/sky.yaml").lexically_normal());
  EXPECT_EQ(sim.sky, SkySimSettings::Sky::Clear);
  EXPECT_EQ(sim.start, skylit::sky::parse_utc("2026-06-21T00:00:00Z"));
  EXPECT_EQ(sim.step, std::chrono::minutes(10));
  EXPECT_EQ(sim.frames, 12);
  EXPECT_DOUBLE_EQ(sim.latitude_deg, 34.68);
  EXPECT_DOUBLE_EQ(sim.turbidity, 4.0);
  EXPECT_EQ(sim.exposure_time, 0.05);
}

struct BadCase {
  std::string name;
  std::string yaml;
  std::string expected;  // a part of the message
};

// One test for all cases: each test process loads OpenCV's video I/O (a quarter second).
TEST(SourceConfig, ErrorsNameTheFileLineColumnFieldAndFix) {
  const BadCase cases[] = {
      BadCase{"NoSource", "other: 1\n", "field 'source': missing"},
      BadCase{"UnknownKind", "source:\n  kind: imagse\n", "live.yaml:2:9: field 'source.kind': unknown kind 'imagse'. Fix: did you mean 'images'?"},
      BadCase{"UnknownField", "source:\n  kind: images\n  path: a\n  fsp: 3\n", "live.yaml:4:3: field 'source.fsp': unknown field. Fix: did you mean 'fps'?"},
      BadCase{"FieldOfAnotherKind", "source:\n  kind: video\n  path: a.avi\n  fps: 3\n", "live.yaml:4:3: field 'source.fps': unknown field"},
      BadCase{"NotANumber", "source:\n  kind: images\n  path: a\n  fps: fast\n", "live.yaml:4:8: field 'source.fps': 'fast' is not a number"},
      BadCase{"Negative", "source:\n  kind: images\n  path: a\n  fps: -2\n", "field 'source.fps': must be positive"},
      BadCase{"MissingPath", "source:\n  kind: video\n", "field 'source.path': required field is missing"},
      BadCase{"ClearWithoutStart", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: clear\n  latitude: 1\n  longitude: 2\n", "field 'source.start': required field is missing"},
      BadCase{"NoZone", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: overcast\n  start: 2026-06-21T09:00:00\n", "live.yaml:5:10: field 'source.start'"},
      BadCase{"BadInterval", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: overcast\n  every: often\n", "live.yaml:5:10: field 'source.every': 'often' is not an interval"},
      BadCase{"BadSky", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: cloudy\n", "field 'source.sky': unknown sky 'cloudy'"},
      BadCase{"Latitude", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: clear\n  start: 2026-06-21T00:00:00Z\n  latitude: 95\n  longitude: 2\n", "live.yaml:6:13: field 'source.latitude': 95 is outside [-90, 90]"},
      BadCase{"Turbidity", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: overcast\n  turbidity: 1\n", "field 'source.turbidity'"},
      BadCase{"EquirectForClear", "source:\n  kind: sky-sim\n  calibration: c.yaml\n  sky: overcast\n  equirect: e.exr\n", "field 'source.equirect': only used with 'sky: equirect'"},
      BadCase{"PixelFormat", "source:\n  kind: libcamera\n  pixel_format: SRGGB12\n", "live.yaml:3:17: field 'source.pixel_format': 'SRGGB12' is not supported"},
      BadCase{"BufferCount", "source:\n  kind: libcamera\n  buffer_count: 0\n", "field 'source.buffer_count': 0 is outside 1..32"},
      BadCase{"Fourcc", "source:\n  kind: v4l2\n  fourcc: MJPEG\n", "field 'source.fourcc': 'MJPEG' is not four characters"},
      BadCase{"WidthAlone", "source:\n  kind: v4l2\n  width: 640\n", "field 'source.height': width and height go together"},
      BadCase{"RealtimeCamera", "source:\n  kind: v4l2\n  realtime: true\n", "field 'source.realtime': a camera is always real time"},
      BadCase{"ReconnectKey", "source:\n  kind: v4l2\n  reconnect: {initial: 1, maxx: 5}\n", "live.yaml:3:27: field 'source.reconnect.maxx': unknown field. Fix: did you mean 'max'?"},
      BadCase{"ReconnectMax", "source:\n  kind: v4l2\n  reconnect: {initial: 5, max: 1}\n", "field 'source.reconnect.max': shorter than reconnect.initial"},
      BadCase{"Twice", "source:\n  kind: images\n  path: a\n  path: b\n", "field 'source.path': the field appears twice"},
      BadCase{"Syntax", "source:\n  kind: [images\n", "YAML syntax error"}};
  TempDir dir;
  for (const BadCase& bad : cases) {
    SCOPED_TRACE(bad.name);
    const fs::path file = dir.write("live.yaml", bad.yaml);
    const std::string message = error_of(file);
    EXPECT_NE(message.find(file.string()), std::string::npos) << message;
    EXPECT_NE(message.find(bad.expected), std::string::npos) << message;
    EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
  }
}

TEST(OpenSource, OpensImagesNamedAndPacedAsConfigured) {
  TempDir dir;
  ASSERT_TRUE(cv::imwrite((dir.path() / "a.png").string(), grey(4, 4, 1)));
  ASSERT_TRUE(cv::imwrite((dir.path() / "b.png").string(), grey(4, 4, 2)));
  const SourceConfig config = load_source_config(
      dir.write("live.yaml", "source:\n  kind: images\n  name: sky\n  path: .\n  fps: 1\n  realtime: 2\n"));
  skylit::capture::testing::FakeTime time;
  std::unique_ptr<FrameSource> source = open_source(config, time.clock());
  FrameResult first = source->next(1.0);
  ASSERT_EQ(first.status, FrameStatus::Ready);
  EXPECT_EQ(first.frame.source, "sky");
  EXPECT_EQ(source->next(0.1).status, FrameStatus::NotYet);  // due 0.5 s later at speed 2
  FrameResult second = source->next(1.0);
  ASSERT_EQ(second.status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(time.now, 0.5);
  EXPECT_EQ(source->next(1.0).status, FrameStatus::EndOfStream);
  EXPECT_EQ(source->counts().delivered, 2);
}

TEST(OpenSource, AnAbsentCameraFailsAtStartWithTheCamerasPresent) {
  TempDir dir;
  const SourceConfig config = load_source_config(dir.write("live.yaml", "source:\n  kind: v4l2\n  device: /dev/video97\n"));
  try {
    open_source(config);
    FAIL() << "an absent camera opened";
  } catch (const skylit::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras present: " + describe_devices(list_v4l2_devices())),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
