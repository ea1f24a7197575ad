// The `pose:` node of a config file.
#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/track/pose.hpp"

namespace skylit::track {
namespace {

namespace fs = std::filesystem;

constexpr std::array<std::string_view, 5> kFixedKeys{"kind", "position", "orientation", "look_at", "up"};
constexpr std::array<std::string_view, 2> kTrackKeys{"kind", "csv"};
constexpr std::array<std::string_view, 2> kKinds{"fixed", "track"};
const char* const kDocs = "see docs/live.md (Pose)";

// The shared YAML reader, with the `pose.` prefix on field names.
class Reader : public YamlReader {
 public:
  using YamlReader::YamlReader;

  void check_keys(const YAML::Node& map, std::span<const std::string_view> allowed) const {
    YamlReader::check_keys(map, "pose.", allowed);
  }
  YAML::Node require(const YAML::Node& map, const std::string& key, const std::string& fix) const {
    return YamlReader::require(map, key, "pose." + key, fix);
  }
  std::vector<double> numbers(const YAML::Node& node, const std::string& field, std::size_t count,
                              const std::string& fix) const {
    return YamlReader::numbers(node, count, field, fix);
  }
  Vec3 vector3(const YAML::Node& node, const std::string& field, const std::string& fix) const {
    const auto v = numbers(node, field, 3, fix);
    return Vec3(v[0], v[1], v[2]);
  }
};

}  // namespace

PoseConfig parse_pose_config(const YAML::Node& node, const fs::path& file) {
  const Reader r(file);
  if (!node.IsDefined() || node.IsNull()) r.fail(node, "pose", "missing", std::string("add a 'pose:' map with a kind; ") + kDocs);
  if (!node.IsMap()) r.fail(node, "pose", "expected a map of fields", std::string("write 'kind: fixed' or 'kind: track' and its fields; ") + kDocs);
  const std::string kind_fix = "write 'kind: fixed' (position and orientation or look_at) or 'kind: track' (csv)";
  const YAML::Node kind_node = r.require(node, "kind", kind_fix);
  const std::string kind = kind_node.IsScalar() ? kind_node.Scalar() : std::string();

  PoseConfig config;
  if (kind == "fixed") {
    r.check_keys(node, kFixedKeys);
    config.kind = PoseConfig::Kind::Fixed;
    const std::string position_fix = "write the camera's position in the site frame (x east, y north, z up), metres, e.g. [0, 0, 1.6]";
    config.fixed.t_site_from_camera = r.vector3(r.require(node, "position", position_fix), "pose.position", position_fix);
    const YAML::Node orientation = Reader::optional(node, "orientation");
    const YAML::Node target = Reader::optional(node, "look_at");
    const std::string orientation_fix =
        "give 'orientation: [qw, qx, qy, qz]' (R_site_from_camera, unit length) or 'look_at: [x, y, z]' (a site point)";
    if (orientation.IsDefined() == target.IsDefined()) {
      r.fail(orientation.IsDefined() ? orientation : node, "pose.orientation",
             orientation.IsDefined() ? "both orientation and look_at are given" : "neither orientation nor look_at is given",
             orientation_fix);
    }
    if (orientation.IsDefined()) {
      if (const auto up = Reader::optional(node, "up")) r.fail(up, "pose.up", "only used with look_at", "remove it");
      const auto q = r.numbers(orientation, "pose.orientation", 4, orientation_fix);
      const Eigen::Quaterniond quaternion(q[0], q[1], q[2], q[3]);
      if (std::abs(quaternion.norm() - 1.0) > 1e-3) {
        r.fail(orientation, "pose.orientation", "the quaternion's length is " + std::to_string(quaternion.norm()) + ", not 1",
               "write a unit quaternion qw, qx, qy, qz, e.g. [1, 0, 0, 0]");
      }
      config.fixed.R_site_from_camera = quaternion.normalized();
    } else {
      const std::string target_fix = "write a site point the camera looks at, e.g. [10, 0, 1.6]";
      const Vec3 point = r.vector3(target, "pose.look_at", target_fix);
      Vec3 up = Vec3::UnitZ();
      const YAML::Node up_node = Reader::optional(node, "up");
      if (up_node.IsDefined()) up = r.vector3(up_node, "pose.up", "write a site direction, e.g. [0, 0, 1]");
      try {
        config.fixed.R_site_from_camera = look_at(config.fixed.t_site_from_camera, point, up);
      } catch (const std::invalid_argument&) {
        const bool same = (point - config.fixed.t_site_from_camera).norm() <= 1e-12;
        r.fail(same ? target : (up_node.IsDefined() ? up_node : target), same ? "pose.look_at" : "pose.up",
               same ? "the point is the camera's position" : "the view is parallel to 'up'",
               same ? target_fix : "give an 'up' direction across the view, e.g. up: [0, 1, 0] when looking straight up");
      }
    }
  } else if (kind == "track") {
    r.check_keys(node, kTrackKeys);
    config.kind = PoseConfig::Kind::Track;
    const std::string csv_fix = "write the pose CSV's path (timestamp,x,y,z,qw,qx,qy,qz), e.g. 'csv: head_track.csv'";
    const YAML::Node csv = r.require(node, "csv", csv_fix);
    if (!csv.IsScalar() || csv.Scalar().empty()) r.fail(csv, "pose.csv", "expected a file name", csv_fix);
    const fs::path path(csv.Scalar());
    config.csv = path.is_absolute() ? path : (file.parent_path() / path).lexically_normal();
  } else {
    r.fail(kind_node, "pose.kind", "unknown kind '" + kind + "'", unknown_key_fix(kind, std::span<const std::string_view>(kKinds)));
  }
  return config;
}

PoseConfig load_pose_config(const fs::path& file) {
  const std::string text = read_file(file);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw InputError(input_message(file, e.mark.line + 1, e.mark.column + 1, "", "YAML syntax error: " + e.msg,
                                   "correct the YAML syntax at that line (indentation, colons, brackets)"));
  }
  if (!root.IsMap()) {
    throw InputError(input_message(file, -1, -1, "pose", "the file has no top-level map",
                                   std::string("write 'pose:' with a kind and its fields; ") + kDocs));
  }
  return parse_pose_config(root["pose"], file);
}

std::unique_ptr<PoseSource> open_pose_source(const PoseConfig& config) {
  if (config.kind == PoseConfig::Kind::Track) return std::make_unique<PoseTrack>(PoseTrack::load(config.csv));
  return std::make_unique<FixedPose>(config.fixed);
}

}  // namespace skylit::track
