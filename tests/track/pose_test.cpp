// Pose sources: a fixed pose, look_at, a recorded pose track (linear position, slerp, clamped
// ends), and the CSV and YAML errors.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <unistd.h>

#include <gtest/gtest.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/track/pose.hpp"

namespace pose_test {  // named, not anonymous: the test program is one unity build

using namespace skylit::track;
namespace fs = std::filesystem;
using skylit::test::TempDir;
using skylit::test::error_of;
constexpr double kPi = std::numbers::pi;


// The angle between two rotations, radians.
double angle_between(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) { return a.angularDistance(b); }

Eigen::Quaterniond about_z(double angle) { return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Vec3::UnitZ())); }

TEST(LookAt, LooksNorthWithTheImageUpright) {
  const Eigen::Matrix3d R = look_at(Vec3(0, 0, 1.6), Vec3(0, 10, 1.6)).toRotationMatrix();
  EXPECT_LT((R.col(0) - Vec3(1, 0, 0)).norm(), 1e-12) << "camera x (right) is east";
  EXPECT_LT((R.col(1) - Vec3(0, 0, -1)).norm(), 1e-12) << "camera y (down) is down";
  EXPECT_LT((R.col(2) - Vec3(0, 1, 0)).norm(), 1e-12) << "camera z (forward) is north";
  // Looking east and down at 45°: the optical axis hits the target.
  const Eigen::Quaterniond q = look_at(Vec3(1, 2, 3), Vec3(4, 2, 0));
  EXPECT_LT((q * Vec3::UnitZ() - Vec3(1, 0, -1).normalized()).norm(), 1e-12);
  EXPECT_NEAR((q * Vec3::UnitX()).z(), 0.0, 1e-12) << "no roll: the image's x stays level";
  EXPECT_THROW(look_at(Vec3(0, 0, 0), Vec3(0, 0, 5)), std::invalid_argument);
  EXPECT_THROW(look_at(Vec3(1, 1, 1), Vec3(1, 1, 1)), std::invalid_argument);
  const Eigen::Quaterniond up = look_at(Vec3(0, 0, 0), Vec3(0, 0, 5), Vec3::UnitY());
  EXPECT_LT((up * Vec3::UnitZ() - Vec3::UnitZ()).norm(), 1e-12);
}

TEST(FixedPose, ReturnsItsPoseStampedWithTheTimeAsked) {
  Pose pose;
  pose.t_site_from_camera = Vec3(1, 2, 1.6);
  pose.R_site_from_camera = about_z(0.3);
  FixedPose source(pose);
  const auto at = source.pose_at(42.5);
  ASSERT_TRUE(at.has_value());
  EXPECT_DOUBLE_EQ(at->timestamp, 42.5);
  EXPECT_EQ(at->t_site_from_camera, pose.t_site_from_camera);
  EXPECT_LT(angle_between(at->R_site_from_camera, pose.R_site_from_camera), 1e-15);
  EXPECT_EQ(source.describe(), "fixed pose at (1.000, 2.000, 1.600)");
}

TEST(PoseTrack, InterpolatesPositionLinearlyAndRotationBySlerp) {
  TempDir dir;
  // From 0 to 90° about z between t = 10 and t = 12, while moving 4 m east and 1 m up.
  const double c = std::cos(kPi / 4), s = std::sin(kPi / 4);
  const fs::path csv = dir.write("head.csv", "timestamp,x,y,z,qw,qx,qy,qz\n"
                                             "10,0,0,1,1,0,0,0\n"
                                             "12,4,0,2," + std::to_string(c) + ",0,0," + std::to_string(s) + "\n"
                                             "# a comment, then a blank line\n\n"
                                             "13,4,0,2,0,0,0,1\n");
  PoseTrack track = PoseTrack::load(csv);
  ASSERT_EQ(track.samples().size(), 3u);
  EXPECT_EQ(track.describe(), "pose track head.csv (3 poses)");
  for (const double t : {10.0, 10.5, 11.0, 11.5, 12.0}) {
    const auto pose = track.pose_at(t);
    ASSERT_TRUE(pose.has_value());
    const double f = (t - 10.0) / 2.0;
    EXPECT_DOUBLE_EQ(pose->timestamp, t);
    EXPECT_LT((pose->t_site_from_camera - Vec3(4 * f, 0, 1 + f)).norm(), 1e-12) << t;
    // Slerp turns at a constant rate: f · 90° about z (6-digit CSV values: 1e-6 rad).
    EXPECT_LT(angle_between(pose->R_site_from_camera, about_z(f * kPi / 2)), 2e-6) << t;
  }
  // 90° to 180° about z between 12 and 13.
  EXPECT_LT(angle_between(track.pose_at(12.5)->R_site_from_camera, about_z(0.75 * kPi)), 2e-6);
  // Clamped at the ends.
  EXPECT_LT((track.pose_at(-100)->t_site_from_camera - Vec3(0, 0, 1)).norm(), 1e-15);
  EXPECT_LT(angle_between(track.pose_at(-100)->R_site_from_camera, Eigen::Quaterniond::Identity()), 1e-15);
  EXPECT_LT(angle_between(track.pose_at(1e6)->R_site_from_camera, about_z(kPi)), 1e-12);
  EXPECT_DOUBLE_EQ(track.pose_at(1e6)->timestamp, 1e6);
}

TEST(PoseTrack, SlerpTakesTheShortWayWhenTheQuaternionSignFlips) {
  Pose a;
  a.timestamp = 0;
  Pose b;
  b.timestamp = 1;
  b.R_site_from_camera = Eigen::Quaterniond(-about_z(0.2).coeffs());  // the same rotation as +q
  PoseTrack track({a, b}, "flip");
  const auto middle = track.pose_at(0.5);
  ASSERT_TRUE(middle.has_value());
  EXPECT_LT(angle_between(middle->R_site_from_camera, about_z(0.1)), 1e-12);
}

TEST(PoseTrack, MalformedLinesNameTheFileLineAndColumn) {
  TempDir dir;
  const auto load = [&](const std::string& name, const std::string& text) {
    const fs::path file = dir.write(name, text);
    return error_of([&] { PoseTrack::load(file); });
  };
  std::string message = load("a.csv", "t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n");
  EXPECT_NE(message.find("a.csv:1:1: the header is not 'timestamp,x,y,z,qw,qx,qy,qz'"), std::string::npos) << message;
  message = load("b.csv", "timestamp,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,zero,0,1,0,0,0\n");
  EXPECT_NE(message.find("b.csv:3:5: field 'y': 'zero' is not a number"), std::string::npos) << message;
  message = load("c.csv", "timestamp,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0\n");
  EXPECT_NE(message.find("c.csv:2:13: 7 fields, 8 expected"), std::string::npos) << message;
  message = load("d.csv", "timestamp,x,y,z,qw,qx,qy,qz\n0,0,0,0,2,0,0,0\n");
  EXPECT_NE(message.find("d.csv:2:9: field 'qw': the quaternion's length is 2, not 1"), std::string::npos) << message;
  message = load("e.csv", "timestamp,x,y,z,qw,qx,qy,qz\n5,0,0,0,1,0,0,0\n5,1,0,0,1,0,0,0\n");
  EXPECT_NE(message.find("e.csv:3:1: field 'timestamp': does not increase (5 after 5)"), std::string::npos) << message;
  message = load("f.csv", "timestamp,x,y,z,qw,qx,qy,qz\n");
  EXPECT_NE(message.find("no poses after the header"), std::string::npos) << message;
  message = error_of([&] { PoseTrack::load(dir.path() / "missing.csv"); });
  EXPECT_NE(message.find("missing.csv"), std::string::npos) << message;
  message = load("g.csv", "timestamp,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0,9\n");
  EXPECT_NE(message.find("g.csv:2:17: 9 fields, 8 expected"), std::string::npos) << message;
  EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
}

TEST(PoseConfig, ReadsFixedPosesAndTracks) {
  TempDir dir;
  PoseConfig config = load_pose_config(dir.write("a.yaml", "pose:\n  kind: fixed\n  position: [1, 2, 1.6]\n"
                                                           "  orientation: [0.7071068, 0, 0, 0.7071068]\n"));
  EXPECT_EQ(config.kind, PoseConfig::Kind::Fixed);
  EXPECT_EQ(config.fixed.t_site_from_camera, Vec3(1, 2, 1.6));
  EXPECT_LT(angle_between(config.fixed.R_site_from_camera, about_z(kPi / 2)), 1e-6);

  config = load_pose_config(dir.write("b.yaml", "pose:\n  kind: fixed\n  position: [0, 0, 1.6]\n  look_at: [0, 10, 1.6]\n"));
  EXPECT_LT(angle_between(config.fixed.R_site_from_camera, look_at(Vec3(0, 0, 1.6), Vec3(0, 10, 1.6))), 1e-15);
  std::unique_ptr<PoseSource> source = open_pose_source(config);
  EXPECT_EQ(source->describe(), "fixed pose at (0.000, 0.000, 1.600)");

  dir.write("track.csv", "timestamp,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n2,2,0,0,1,0,0,0\n");
  config = load_pose_config(dir.write("c.yaml", "pose:\n  kind: track\n  csv: track.csv\n"));
  EXPECT_EQ(config.kind, PoseConfig::Kind::Track);
  EXPECT_EQ(config.csv, dir.path() / "track.csv");
  source = open_pose_source(config);
  EXPECT_LT((source->pose_at(0.5)->t_site_from_camera - Vec3(0.5, 0, 0)).norm(), 1e-15);
}

struct BadCase {
  std::string name;
  std::string yaml;
  std::string expected;
};

class PoseConfigErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(PoseConfigErrors, NameTheFileLineColumnFieldAndFix) {
  TempDir dir;
  const fs::path file = dir.write("live.yaml", GetParam().yaml);
  const std::string message = error_of([&] { load_pose_config(file); });
  EXPECT_NE(message.find(file.string()), std::string::npos) << message;
  EXPECT_NE(message.find(GetParam().expected), std::string::npos) << message;
  EXPECT_NE(message.find("Fix:"), std::string::npos) << message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, PoseConfigErrors,
    ::testing::Values(
        BadCase{"Missing", "source: 1\n", "field 'pose': missing"},
        BadCase{"UnknownKind", "pose:\n  kind: tracker\n", "live.yaml:2:9: field 'pose.kind': unknown kind 'tracker'. Fix: did you mean 'track'?"},
        BadCase{"UnknownField", "pose:\n  kind: fixed\n  positon: [0, 0, 0]\n", "live.yaml:3:3: field 'pose.positon': unknown field. Fix: did you mean 'position'?"},
        BadCase{"NoPosition", "pose:\n  kind: fixed\n  look_at: [1, 0, 0]\n", "field 'pose.position': required field is missing"},
        BadCase{"ShortPosition", "pose:\n  kind: fixed\n  position: [0, 0]\n", "live.yaml:3:13: field 'pose.position': expected a list of 3 numbers"},
        BadCase{"BadNumber", "pose:\n  kind: fixed\n  position: [0, x, 0]\n  look_at: [1, 0, 0]\n", "live.yaml:3:17: field 'pose.position': element 1 is not a finite number"},
        BadCase{"NoOrientation", "pose:\n  kind: fixed\n  position: [0, 0, 0]\n", "neither orientation nor look_at is given"},
        BadCase{"Both", "pose:\n  kind: fixed\n  position: [0, 0, 0]\n  orientation: [1, 0, 0, 0]\n  look_at: [1, 0, 0]\n", "live.yaml:4:16: field 'pose.orientation': both orientation and look_at are given"},
        BadCase{"NotUnit", "pose:\n  kind: fixed\n  position: [0, 0, 0]\n  orientation: [1, 1, 0, 0]\n", "field 'pose.orientation': the quaternion's length is 1.414"},
        BadCase{"LookAtSelf", "pose:\n  kind: fixed\n  position: [1, 1, 1]\n  look_at: [1, 1, 1]\n", "live.yaml:4:12: field 'pose.look_at': the point is the camera's position"},
        BadCase{"LookUp", "pose:\n  kind: fixed\n  position: [0, 0, 0]\n  look_at: [0, 0, 9]\n", "field 'pose.up': the view is parallel to 'up'"},
        BadCase{"UpWithOrientation", "pose:\n  kind: fixed\n  position: [0, 0, 0]\n  orientation: [1, 0, 0, 0]\n  up: [0, 0, 1]\n", "field 'pose.up': only used with look_at"},
        BadCase{"TrackWithoutCsv", "pose:\n  kind: track\n", "field 'pose.csv': required field is missing"},
        BadCase{"Syntax", "pose: [\n", "YAML syntax error"}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) { return param_info.param.name; });

}  // namespace
