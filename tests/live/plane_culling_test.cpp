// blend.cull_planes: the service blends only the planes the current view can see. The camera
// first stands at the foot of the tower's south wall looking up at the wall and the roof (the
// ground is out of view) while new skies come, then turns to the rig's usual view, which sees the
// ground and the tower's shadow on it: the ground's blends are left out while it cannot be seen,
// the other planes' run, and every frame is the frame the service draws with culling off (the
// ground comes back into view with T of the current sky, not of the one before it went out).
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "live_fixture.hpp"

namespace skylit::live_test {
namespace {

// R_site_from_camera of a camera at `eye` looking at `target` (OpenCV: x right, y down, z
// forward; the site's z up), as a quaternion.
Eigen::Quaterniond looking_at(const Vector3d& eye, const Vector3d& target) {
  const Vector3d forward = (target - eye).normalized();
  const Vector3d right = forward.cross(Vector3d::UnitZ()).normalized();
  const Vector3d down = forward.cross(right);
  Eigen::Matrix3d R;
  R.col(0) = right;
  R.col(1) = down;
  R.col(2) = forward;
  return Eigen::Quaterniond(R);
}

// 1 m south of the wall, 0.5 m up, looking (nearly) straight up: the wall and the roof.
const Vector3d kLowEye(0.0, -2.0, 0.5);
const Vector3d kLowTarget(0.0, -1.9, 10.0);
constexpr double kTurnStart = 1.0;   // s: the camera turns from the low view to the rig's
constexpr double kTurnEnd = 1.1;

void write_pose_track(const fs::path& csv) {
  std::ofstream out(csv);
  out << "timestamp,x,y,z,qw,qx,qy,qz\n";
  auto line = [&out](double t, const Vector3d& eye, const Vector3d& target) {
    const Eigen::Quaterniond q = looking_at(eye, target);
    out << t << ',' << eye.x() << ',' << eye.y() << ',' << eye.z() << ',' << q.w() << ',' << q.x() << ',' << q.y()
        << ',' << q.z() << '\n';
  };
  line(0.0, kLowEye, kLowTarget);
  line(kTurnStart, kLowEye, kLowTarget);
  line(kTurnEnd, kEye, kTarget);
  line(100.0, kEye, kTarget);
}

struct CullRun {
  std::string error;
  nlohmann::json status;
  // By camera and sky timestamp (the frame log's text): which sky a frame was drawn with
  // depends on when the skies came, which differs from run to run.
  std::map<std::pair<std::string, std::string>, cv::Mat> frames_with_sky;
};

CullRun run_service(const std::string& device, bool cull) {
  RigOptions rig_options;
  rig_options.camera_frames = 45;   // 1.5 s at 30 frames/s
  rig_options.camera_loop = false;
  // Played at 0.4 of their pace, so that a loaded machine (a CI runner with every test at once)
  // still draws most frames before the turn instead of dropping them.
  rig_options.camera_realtime = "0.4";
  rig_options.sky_frames = 4;       // a new sky every eighth of a second of camera time, then no more
  rig_options.sky_realtime = "1.6";
  rig_options.pose = "pose:\n  kind: track\n  csv: poses.csv\n";
  rig_options.extra = "tracking:\n  fade_s: 0\nblend:\n  device: " + device + "\n  cull_planes: " +
                      (cull ? "true" : "false") + "\n";
  const Rig rig(rig_options);
  write_pose_track(rig.dir() / "poses.csv");
  CullRun out;
  live::ServiceOptions options = quiet_options();
  options.record = rig.dir() / "recorded";
  {
    RunningService running(rig.config(), options);
    running.join();
    out.error = running.error();
    out.status = running.status();
  }
  std::ifstream log(rig.dir() / "recorded" / "frames.csv");
  std::string line;
  std::getline(log, line);  // header
  while (std::getline(log, line)) {
    std::vector<std::string> fields;
    std::stringstream row(line);
    for (std::string field; std::getline(row, field, ',');) fields.push_back(field);
    if (fields.size() < 4 || fields[3].empty()) continue;  // before the sky: the camera image
    out.frames_with_sky[{fields[2], fields[3]}] = cv::imread((rig.dir() / "recorded" / fields[1]).string(), cv::IMREAD_UNCHANGED);
  }
  return out;
}

const nlohmann::json& plane_status(const nlohmann::json& status, const std::string& name) {
  for (const auto& plane : status["blend"]["planes"]) {
    if (plane["name"] == name) return plane;
  }
  throw std::runtime_error("no plane " + name + " in the status");
}

class PlaneCulling : public ::testing::TestWithParam<std::string> {};

TEST_P(PlaneCulling, APlaneOutOfViewIsNotBlendedAndTheFramesAreThoseWithoutCulling) {
  const CullRun culled = run_service(GetParam(), true);
  ASSERT_TRUE(culled.error.empty()) << culled.error;
  const CullRun every = run_service(GetParam(), false);
  ASSERT_TRUE(every.error.empty()) << every.error;

  // The ground was left out while the upward view could not see it; the roof and wall never were.
  const nlohmann::json& ground = plane_status(culled.status, "ground");
  EXPECT_GE(ground["blends_out_of_view"].get<std::int64_t>(), 1) << culled.status["blend"].dump();
  EXPECT_GE(ground["blends_on_return"].get<std::int64_t>(), 1) << culled.status["blend"].dump();
  for (const char* seen : {"roof", "wall"}) {
    const nlohmann::json& plane = plane_status(culled.status, seen);
    EXPECT_EQ(plane["blends_out_of_view"].get<std::int64_t>(), 0) << seen;
    EXPECT_TRUE(plane["in_view"].get<bool>()) << seen;
  }
  EXPECT_TRUE(ground["in_view"].get<bool>()) << "the rig's view, at the end, sees the ground";
  EXPECT_GE(culled.status["blends"]["run"].get<std::int64_t>(), 2);
  EXPECT_TRUE(culled.status["blend"]["cull_planes"].get<bool>());
  EXPECT_FALSE(every.status["blend"]["cull_planes"].get<bool>());
  for (const char* name : {"ground", "roof", "wall"}) {
    EXPECT_EQ(plane_status(every.status, name)["blends_out_of_view"].get<std::int64_t>(), 0) << name;
  }

  // The same camera frame, drawn with culling and without, is the same image.
  int compared = 0, before_turn = 0, after_turn = 0;
  for (const auto& [timestamps, frame] : culled.frames_with_sky) {
    const auto other = every.frames_with_sky.find(timestamps);
    if (other == every.frames_with_sky.end()) continue;  // dropped by one run, or drawn with another sky
    const std::string& timestamp = timestamps.first;
    ASSERT_FALSE(frame.empty());
    ASSERT_FALSE(other->second.empty());
    EXPECT_EQ(max_difference(frame, other->second), 0) << "camera frame at " << timestamp << " s, sky at " << timestamps.second;
    ++compared;
    ++(std::stod(timestamp) < kTurnStart ? before_turn : after_turn);
  }
  std::printf("measured: blend on the %s: %d frames compared (%d before the turn, %d after); ground: %lld blends "
              "left out of view, %lld on its return\n",
              GetParam().c_str(), compared, before_turn, after_turn,
              static_cast<long long>(ground["blends_out_of_view"].get<std::int64_t>()),
              static_cast<long long>(ground["blends_on_return"].get<std::int64_t>()));
  EXPECT_GE(before_turn, 5);
  EXPECT_GE(after_turn, 3);
}

INSTANTIATE_TEST_SUITE_P(Device, PlaneCulling, ::testing::Values("cpu", "gpu"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace skylit::live_test
