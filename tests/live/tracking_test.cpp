// The marker tracker and the IMU in the live service: a camera recording of a board of tags
// rendered from a known pose (render_markers, through the rig's distorted HMD lens), the pose
// the service draws from (/status), the tracking state when a replayed IMU ends mid-run, and the
// config's errors.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>

#include "../track/marker_scene.hpp"
#include "live_fixture.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/imu.hpp"
#include "skylit/track/marker_map.hpp"
#include "skylit/track/marker_render.hpp"
#include "skylit/camera/lens.hpp"
#include "skylit/camera/stereo_calibration.hpp"

namespace skylit::live_test {
namespace {

using track::Pose;
using track::Vec3;

// The HMD camera of these tests: 240×180, 75° across (f = 156 px), the rig's barrel distortion.
constexpr int kWidth = 240;
constexpr int kHeight = 180;

// Where the recorded camera stands: 3 m south of the board, looking at it a little from the side
// and from above, rolled by 3°.
const Pose kTruth = marker_scene::head(Vec3(6.0, -6.0, 1.6), Vec3(6.2, -3.0, 1.45), 3.0);

// The accuracy asked of the service's pose. Four 60 cm tags at 3 m, 31 px across: the tracker
// alone is within a few millimetres and a few hundredths of a degree (measured below; docs/live.md).
constexpr double kPositionTolerance = 0.02;  // m
constexpr double kRotationToleranceDeg = 0.3;

// Four 60 cm tags on a board 3 m north of the camera (y = −3), 1.4 m × 1.0 m apart, facing south.
track::MarkerMap board() {
  track::MarkerMap map;
  map.family = "tag36h11";
  map.tags = {marker_scene::wall_tag(0, 5.3, 2.0, 0.6, -3.0), marker_scene::wall_tag(1, 6.7, 2.0, 0.6, -3.0),
              marker_scene::wall_tag(2, 5.3, 1.0, 0.6, -3.0), marker_scene::wall_tag(3, 6.7, 1.0, 0.6, -3.0)};
  return map;
}

constexpr const char* kMarkersPose = "pose:\n  kind: markers\n  map: tags.yaml\n  decimation: 1\n";

RigOptions tag_rig_options(const std::string& extra = "") {
  RigOptions options;
  options.hmd_width = kWidth;
  options.hmd_height = kHeight;
  options.pose = kMarkersPose;
  options.extra = extra;
  return options;
}

// The board's map beside the config, and the camera recording replaced by frames of the board
// seen from kTruth (three frames, looping: a still head).
void write_tag_recording(const Rig& rig) {
  track::save_marker_map(board(), rig.dir() / "tags.yaml");
  const camera::Lens lens(camera::load_calibration(rig.dir() / "hmd.yaml"));
  std::vector<cv::Mat> frames;
  for (std::uint64_t k = 0; k < 3; ++k) {
    track::MarkerRenderOptions options;
    options.seed = k + 1;  // each frame its own noise
    cv::Mat bgr;
    cv::cvtColor(track::render_markers(board(), lens, kTruth, options), bgr, cv::COLOR_GRAY2BGR);
    frames.push_back(bgr);
  }
  write_frames(rig.dir() / "camera", frames, 30.0, "png");
}

Pose pose_from_status(const nlohmann::json& last) {
  Pose pose;
  pose.timestamp = last["timestamp"].get<double>();
  pose.t_site_from_camera = Vec3(last["position"][0].get<double>(), last["position"][1].get<double>(),
                                 last["position"][2].get<double>());
  pose.R_site_from_camera = Eigen::Quaterniond(last["orientation"][0].get<double>(), last["orientation"][1].get<double>(),
                                               last["orientation"][2].get<double>(), last["orientation"][3].get<double>());
  return pose;
}

bool has_pose(const nlohmann::json& status) { return status["frames"].get<std::int64_t>() >= 3 && !status["pose"]["last"].is_null(); }

TEST(LiveTracking, MarkersGiveTheRecordedPose) {
  Rig rig(tag_rig_options());
  write_tag_recording(rig);
  RunningService running(rig.config(), quiet_options());
  ASSERT_TRUE(running.wait_for(has_pose, 60)) << running.error() << "\n" << running.status().dump(2);
  const nlohmann::json status = running.status();
  const nlohmann::json& pose = status["pose"];

  const nlohmann::json& latest = pose["markers"]["latest"];
  EXPECT_EQ(latest["tags_seen"], 4) << latest.dump(2);
  EXPECT_TRUE(latest["accepted"].get<bool>());
  EXPECT_EQ(latest["flags"], "ok");
  EXPECT_LT(latest["reprojection_error_px"].get<double>(), 0.5);
  EXPECT_GE(pose["markers"]["accepted"].get<std::int64_t>(), 3);
  EXPECT_EQ(pose["markers"]["errors"], 0);
  // The tracker runs on the camera thread before the frame is handed over: every frame drawn has
  // its own pose.
  EXPECT_EQ(pose["missing"], 0);
  EXPECT_NE(pose["source"].get<std::string>().find("marker tracker"), std::string::npos);
  EXPECT_FALSE(pose.contains("tracking"));  // no imu, no fusion: the tracker's poses as they are

  const Pose drawn = pose_from_status(pose["last"]);
  const double position_error = marker_scene::position_error(drawn, kTruth);
  const double rotation_error = marker_scene::rotation_error_deg(drawn, kTruth);
  std::printf("markers in skylit-live: position error %.2f mm, rotation error %.3f°, reprojection %.3f px\n",
              1e3 * position_error, rotation_error, latest["reprojection_error_px"].get<double>());
  EXPECT_LT(position_error, kPositionTolerance);
  EXPECT_LT(rotation_error, kRotationToleranceDeg);

  const std::string metrics = running.service().metrics_text();
  EXPECT_NE(metrics.find("skylit_marker_tags_seen 4"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skylit_marker_solves_total{result=\"accepted\"}"), std::string::npos);
  EXPECT_NE(metrics.find("skylit_marker_reprojection_error_pixels"), std::string::npos);
  running.finish();
  EXPECT_EQ(running.error(), "");
}

// camera.stereo with the marker tracker: a pair of cameras 64 mm apart, each recording the board
// from its own pose; the tracker solves the left camera's pose from both cameras' tags.
TEST(LiveTracking, AStereoCameraIsTrackedWithBothCameras) {
  Rig rig(tag_rig_options());
  track::save_marker_map(board(), rig.dir() / "tags.yaml");
  camera::StereoCalibration stereo;
  stereo.left = camera::load_calibration(rig.dir() / "hmd.yaml");
  stereo.right = stereo.left;
  stereo.t_right_from_left = Vec3(-0.064, 0, 0);
  camera::save_stereo_calibration(stereo, rig.dir() / "stereo.yaml");
  Pose right_truth = kTruth;  // x_right = x_left + t: the right camera 64 mm along the left's x
  right_truth.t_site_from_camera = kTruth.t_site_from_camera - kTruth.R_site_from_camera * stereo.t_right_from_left;
  const camera::Lens lens(stereo.left);
  for (const auto& [folder, pose] : {std::pair{"left", kTruth}, std::pair{"right", right_truth}}) {
    std::vector<cv::Mat> frames;
    for (std::uint64_t k = 0; k < 3; ++k) {
      track::MarkerRenderOptions options;
      options.seed = k + (folder == std::string("left") ? 1 : 11);
      cv::Mat bgr;
      cv::cvtColor(track::render_markers(board(), lens, pose, options), bgr, cv::COLOR_GRAY2BGR);
      frames.push_back(bgr);
    }
    write_frames(rig.dir() / folder, frames, 30.0, "png");
  }
  std::string text = rig.config_text();
  const std::size_t from = text.find("camera:\n");
  text.replace(from, text.find("pose:", from) - from,
               "camera:\n  stereo: stereo.yaml\n  source:\n    kind: pair\n"
               "    left: {kind: images, path: left, loop: true, realtime: 1}\n"
               "    right: {kind: images, path: right, loop: true, realtime: 1}\n");
  std::ofstream(rig.config_file()) << text;
  RunningService running(rig.config(), quiet_options());
  ASSERT_TRUE(running.wait_for(has_pose, 60)) << running.error() << "\n" << running.status().dump(2);
  const nlohmann::json pose = running.status()["pose"];
  EXPECT_NE(pose["source"].get<std::string>().find("both cameras"), std::string::npos) << pose.dump(2);
  EXPECT_EQ(pose["markers"]["errors"], 0) << pose.dump(2);
  const Pose drawn = pose_from_status(pose["last"]);
  std::printf("markers from a stereo camera in skylit-live: position error %.2f mm, rotation error %.3f°\n",
              1e3 * marker_scene::position_error(drawn, kTruth), marker_scene::rotation_error_deg(drawn, kTruth));
  EXPECT_LT(marker_scene::position_error(drawn, kTruth), kPositionTolerance);
  EXPECT_LT(marker_scene::rotation_error_deg(drawn, kTruth), kRotationToleranceDeg);
  running.finish();
  EXPECT_EQ(running.error(), "");
}

TEST(LiveTracking, FramesWithoutTagsFollowThePoseMissingPath) {
  // The rig's own recording (a grey checker, no tags), played once.
  RigOptions options;
  options.pose = kMarkersPose;
  options.camera_loop = false;
  Rig rig(options);
  track::save_marker_map(board(), rig.dir() / "tags.yaml");
  RunningService running(rig.config(), quiet_options());
  const std::int64_t frames = running.join();
  EXPECT_EQ(running.error(), "");
  const nlohmann::json status = running.status();
  // Never a pose: the building is never drawn (only camera images shown before the sky came).
  EXPECT_EQ(frames, status["frames_without_sky"].get<std::int64_t>());
  // Every frame the renderer took had no pose (it may have dropped some); the tracker saw all three.
  EXPECT_EQ(status["pose"]["missing"].get<std::int64_t>() + status["dropped_frames"].get<std::int64_t>(), 3);
  EXPECT_TRUE(status["pose"]["last"].is_null());
  EXPECT_EQ(status["pose"]["markers"]["rejected"], 3);
  EXPECT_EQ(status["pose"]["markers"]["latest"]["flags"], "no tags");
  EXPECT_EQ(status["pose"]["markers"]["latest"]["tags_seen"], 0);
  EXPECT_TRUE(has_flag(status, "markers_not_accepted")) << status["flags"].dump();
}

// One line of a recording's frame log: the camera frame's timestamp and the building's opacity
// (none for frames shown before the sky came).
struct LoggedFrame {
  std::string file;
  double timestamp = 0;
  std::optional<double> opacity;
};

std::vector<LoggedFrame> read_frame_log(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) header.push_back(field);
  }
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const std::size_t file = column("file"), timestamp = column("timestamp"), opacity = column("opacity");
  std::vector<LoggedFrame> frames;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    LoggedFrame f;
    f.file = fields.at(file);
    f.timestamp = std::stod(fields.at(timestamp));
    if (opacity < fields.size() && !fields[opacity].empty()) f.opacity = std::stod(fields[opacity]);
    frames.push_back(f);
  }
  return frames;
}

TEST(LiveTracking, BuildingFadesOutWhenTagsVanishAndInAgainAtTheNewPose) {
  // 30 Hz, played once: 1 s of the board seen from kTruth, 0.8 s without tags (the board gone),
  // 1 s of the board seen from another place. The tracker keeps a pose 0.12 s after its last
  // solve; tracking.fade_s 0.3.
  constexpr double kFps = 30.0, kFade = 0.3, kMaxAge = 0.12;
  constexpr double kLogged = 1e-4;  // the frame log writes the opacity to 4 decimals
  constexpr int kBefore = 30, kLost = 24, kAfter = 30;
  const Pose elsewhere = marker_scene::head(Vec3(5.0, -5.5, 1.8), Vec3(6.0, -3.0, 1.5), -2.0);
  RigOptions options = tag_rig_options("tracking:\n  fade_s: 0.3\n");
  options.pose = "pose:\n  kind: markers\n  map: tags.yaml\n  decimation: 1\n  max_age: 0.12\n";
  options.camera_loop = false;
  Rig rig(options);
  track::save_marker_map(board(), rig.dir() / "tags.yaml");
  const camera::Lens lens(camera::load_calibration(rig.dir() / "hmd.yaml"));
  std::vector<cv::Mat> frames;
  for (int k = 0; k < kBefore + kLost + kAfter; ++k) {
    track::MarkerRenderOptions render_options;
    render_options.seed = static_cast<std::uint64_t>(k + 1);
    const bool lost = k >= kBefore && k < kBefore + kLost;
    const track::MarkerMap map = lost ? track::MarkerMap{} : board();
    cv::Mat bgr;
    cv::cvtColor(track::render_markers(map, lens, k < kBefore ? kTruth : elsewhere, render_options), bgr, cv::COLOR_GRAY2BGR);
    frames.push_back(bgr);
  }
  write_frames(rig.dir() / "camera", frames, kFps, "png");
  live::ServiceOptions service_options = quiet_options();
  service_options.record = rig.dir() / "recorded";
  RunningService running(rig.config(), service_options);

  // While the tags are gone: the building hidden, said so in /status.
  const bool hidden = running.wait_for([](const nlohmann::json& s) {
    return s["opacity"].get<double>() == 0.0 && s["pose"]["fade"]["state"] == "hidden" && has_flag(s, "pose_lost");
  }, 60);
  EXPECT_TRUE(hidden) << running.error() << "\n" << running.status().dump(2);
  running.join();
  ASSERT_EQ(running.error(), "");
  const nlohmann::json status = running.status();
  EXPECT_EQ(status["opacity"], 1.0) << status["pose"].dump(2);
  EXPECT_EQ(status["pose"]["fade"]["state"], "shown");
  EXPECT_EQ(status["pose"]["fade"]["fade_s"], kFade);
  EXPECT_GT(status["pose"]["missing"].get<std::int64_t>(), 0);
  EXPECT_LT(marker_scene::position_error(pose_from_status(status["pose"]["last"]), elsewhere), kPositionTolerance);

  const std::vector<LoggedFrame> logged = read_frame_log(rig.dir() / "recorded" / "frames.csv");
  // The last frame with a pose before the loss is at most last_pose_at; the tags are back at back_at.
  const double last_pose_at = (kBefore - 1) / kFps + kMaxAge, back_at = (kBefore + kLost) / kFps;
  int with_opacity = 0, in_between = 0, hidden_frames = 0, first_back = -1;
  double previous = 1.0;
  std::string trace;
  for (std::size_t k = 0; k < logged.size(); ++k) {
    const LoggedFrame& f = logged[k];
    if (!f.opacity) continue;  // before the sky: the camera image alone
    ++with_opacity;
    const double opacity = *f.opacity;
    char entry[48];
    std::snprintf(entry, sizeof entry, " %.3f:%.2f", f.timestamp, opacity);
    trace += entry;
    const cv::Mat recorded = cv::imread((rig.dir() / "recorded" / f.file).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat& input = frames.at(static_cast<std::size_t>(std::lround(f.timestamp * kFps)));
    const int to_camera = max_difference(recorded, input);
    if (f.timestamp <= last_pose_at) {
      EXPECT_EQ(opacity, 1.0) << "t " << f.timestamp;  // tracked, the building shown
      EXPECT_GT(to_camera, 10) << "t " << f.timestamp << ": the building should be in view";
    } else if (f.timestamp < back_at - 1e-6) {
      // The pose is lost: the building fades out at the last pose, never up again.
      EXPECT_LE(opacity, previous) << "t " << f.timestamp;
      EXPECT_LE(opacity, std::max(0.0, 1.0 - (f.timestamp - last_pose_at) / kFade) + kLogged) << "t " << f.timestamp;
      if (opacity > 0.0 && opacity < 1.0) ++in_between;
      if (opacity == 0.0) {
        ++hidden_frames;
        EXPECT_EQ(to_camera, 0) << "t " << f.timestamp << ": hidden, the camera image unchanged";
      }
    } else {
      if (first_back < 0) {
        // The first frame at the new pose: from nothing, the camera image exactly.
        first_back = static_cast<int>(k);
        EXPECT_EQ(opacity, 0.0) << "t " << f.timestamp;
        EXPECT_EQ(to_camera, 0) << "t " << f.timestamp;
      }
      EXPECT_GE(opacity, previous) << "t " << f.timestamp;  // fading in, never down again
      EXPECT_LE(opacity, std::min(1.0, (f.timestamp - back_at) / kFade) + kLogged) << "t " << f.timestamp;
      if (opacity > 0.0 && opacity < 1.0) ++in_between;
    }
    previous = opacity;
  }
  std::printf("measured: fade: %d frames composited, %d hidden, %d part faded; t:opacity%s\n", with_opacity, hidden_frames,
              in_between, trace.c_str());
  EXPECT_GT(with_opacity, 50);
  EXPECT_GT(hidden_frames, 3);
  EXPECT_GT(in_between, 2);
  EXPECT_GE(first_back, 0);
  EXPECT_EQ(previous, 1.0);  // shown again at the end
}

// A still head: the gyro reads nothing (a small bias), the accelerometer gravity, in the camera's
// frame (the IMU mounted along the camera), for the first `seconds` of the recording.
void write_still_imu(const fs::path& csv, const Pose& head, double seconds) {
  std::vector<track::ImuSample> samples;
  for (int k = 0; k <= static_cast<int>(seconds * 200); ++k) {
    track::ImuSample s;
    s.timestamp = k / 200.0;
    s.gyro = Vec3(0.002, -0.001, 0.0015);
    s.accel = head.R_site_from_camera.conjugate() * Vec3(0, 0, 9.80665);
    samples.push_back(s);
  }
  track::save_imu_csv(csv, samples);
}

TEST(LiveTracking, ReplayedImuIsFusedThenCameraAloneWhenItEnds) {
  // camera_timeout above the default 0.2 s: on a loaded machine the prediction to the display
  // may reach further than that past the newest camera pose, which is coasting, not tracking.
  Rig rig(tag_rig_options("imu:\n  kind: replay\n  csv: imu.csv\nfusion:\n  camera_timeout: 0.3\n"));
  write_tag_recording(rig);
  // 1.5 s of IMU; the camera recording loops on: the IMU ends mid-run like an unplugged device.
  write_still_imu(rig.dir() / "imu.csv", kTruth, 1.5);
  RunningService running(rig.config(), quiet_options());

  const auto tracking_is = [](const std::string& link) {
    return [link](const nlohmann::json& status) {
      return has_pose(status) && status["pose"]["tracking"]["imu_link"] == link &&
             status["pose"]["tracking"]["state"] == "tracking";
    };
  };
  ASSERT_TRUE(running.wait_for(tracking_is("live"), 60)) << running.error() << "\n" << running.status()["pose"].dump(2);
  const nlohmann::json fused = running.status();
  EXPECT_GT(fused["pose"]["tracking"]["imu_samples"].get<std::int64_t>(), 0);
  EXPECT_EQ(fused["pose"]["imu"]["state"], "streaming");
  EXPECT_GT(fused["pose"]["tracking"]["confidence"].get<double>(), 0.0);
  const Pose with_imu = pose_from_status(fused["pose"]["last"]);
  EXPECT_LT(marker_scene::position_error(with_imu, kTruth), kPositionTolerance);
  EXPECT_LT(marker_scene::rotation_error_deg(with_imu, kTruth), kRotationToleranceDeg);

  // The recording ends at 1.5 s: the IMU is gone, the camera poses alone keep the pose.
  ASSERT_TRUE(running.wait_for(tracking_is("gone"), 30)) << running.error() << "\n" << running.status()["pose"].dump(2);
  const nlohmann::json alone = running.status();
  EXPECT_EQ(alone["pose"]["imu"]["state"], "gone");
  EXPECT_TRUE(has_flag(alone, "imu_gone")) << alone["flags"].dump();
  EXPECT_FALSE(has_flag(alone, "tracking_lost"));
  const Pose camera_only = pose_from_status(alone["pose"]["last"]);
  EXPECT_GT(camera_only.timestamp, with_imu.timestamp);
  const double position_error = marker_scene::position_error(camera_only, kTruth);
  const double rotation_error = marker_scene::rotation_error_deg(camera_only, kTruth);
  std::printf("fused with the IMU: %.2f mm, %.3f°; after it ended: %.2f mm, %.3f°; display delay %.1f ms\n",
              1e3 * marker_scene::position_error(with_imu, kTruth), marker_scene::rotation_error_deg(with_imu, kTruth),
              1e3 * position_error, rotation_error, 1e3 * alone["pose"]["tracking"]["display_delay_s"].get<double>());
  EXPECT_LT(position_error, kPositionTolerance);
  EXPECT_LT(rotation_error, kRotationToleranceDeg);
  EXPECT_EQ(alone["pose"]["missing"], 0);

  const std::string metrics = running.service().metrics_text();
  EXPECT_NE(metrics.find("skylit_tracking_state{state=\"tracking\"} 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("skylit_imu_samples_total"), std::string::npos);
  running.finish();
  EXPECT_EQ(running.error(), "");
}

std::string load_error(const Rig& rig) {
  try {
    (void)rig.config();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(LiveTracking, MissingMarkerMapIsRefusedNamingTheFileAndField) {
  RigOptions options;
  options.pose = "pose:\n  kind: markers\n  map: site_tags.yaml\n";
  Rig rig(options);
  const std::string message = load_error(rig);
  EXPECT_NE(message.find(rig.config_file().string()), std::string::npos) << message;
  EXPECT_NE(message.find("pose.map"), std::string::npos) << message;
  EXPECT_NE(message.find("site_tags.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix"), std::string::npos) << message;
}

TEST(LiveTracking, ImuWithoutMarkersIsRefused) {
  RigOptions options;  // the fixed pose
  options.extra = "imu:\n  kind: replay\n  csv: imu.csv\n";
  Rig rig(options);
  const std::string message = load_error(rig);
  EXPECT_NE(message.find(rig.config_file().string()), std::string::npos) << message;
  EXPECT_NE(message.find("field 'imu'"), std::string::npos) << message;
  EXPECT_NE(message.find("kind: markers"), std::string::npos) << message;
}

TEST(LiveTracking, MissingImuRecordingIsRefusedNamingTheFileAndField) {
  Rig rig(tag_rig_options("imu:\n  kind: replay\n  csv: head_imu.csv\n"));
  track::save_marker_map(board(), rig.dir() / "tags.yaml");
  const std::string message = load_error(rig);
  EXPECT_NE(message.find("imu.csv"), std::string::npos) << message;
  EXPECT_NE(message.find("head_imu.csv"), std::string::npos) << message;
}

}  // namespace
}  // namespace skylit::live_test
