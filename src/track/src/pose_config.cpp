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
constexpr std::array<std::string_view, 20> kMarkerKeys{
    "kind",          "map",          "calibration",      "decimation",            "blur",
    "refine_edges",  "sharpening",   "min_contrast",     "threads",               "max_hamming",
    "min_margin",    "outlier_px",   "max_error_px",     "max_ambiguity",         "distinct_deg",
    "distant_tag_px", "max_age",     "accept_ambiguous", "accept_single_distant",
    "cameras"};
constexpr std::array<std::string_view, 3> kPoseKinds{"fixed", "track", "markers"};
const char* const kPoseDocs = "see docs/live.md (Pose)";

std::string format_range(double lo, double hi) {
  const auto text = [](double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  };
  return text(lo) + ".." + text(hi);
}

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

// The marker tracker's fields (docs/tracking.md): the map, an optional calibration, the knobs.
void parse_markers(const Reader& r, const YAML::Node& node, PoseConfig& config) {
  const std::string map_fix = "write the marker map's path, e.g. 'map: site_tags.yaml' (docs/tracking.md)";
  config.marker_map = r.path(r.require(node, "map", map_fix), "pose.map", map_fix);
  if (const YAML::Node calibration = Reader::optional(node, "calibration")) {
    config.marker_calibration =
        r.path(calibration, "pose.calibration", "write the HMD camera's calibration YAML, or leave it out to use camera.calibration");
  }
  MarkerTrackerOptions& o = config.markers;
  const auto number_or = [&](const char* key, double fallback, double lo, double hi, const std::string& fix) {
    const YAML::Node value = Reader::optional(node, key);
    if (!value.IsDefined()) return fallback;
    const std::string field = std::string("pose.") + key;
    const double v = r.number(value, field, fix);
    if (v < lo || v > hi) r.fail(value, field, value.Scalar() + " is outside " + format_range(lo, hi), fix);
    return v;
  };
  const auto integer_or = [&](const char* key, int fallback, int lo, int hi, const std::string& fix) {
    const YAML::Node value = Reader::optional(node, key);
    return value.IsDefined() ? static_cast<int>(r.integer(value, std::string("pose.") + key, lo, hi, fix)) : fallback;
  };
  const auto boolean_or = [&](const char* key, bool fallback) {
    const YAML::Node value = Reader::optional(node, key);
    return value.IsDefined() ? r.boolean(value, std::string("pose.") + key, "write true or false") : fallback;
  };
  o.detector.decimation = number_or("decimation", o.detector.decimation, 1, 16,
                                    "1 (full resolution) to 16; 2 is the default, see docs/tracking.md for the cost");
  o.detector.blur_sigma = number_or("blur", o.detector.blur_sigma, -10, 10, "a Gaussian σ in pixels; 0 = none, negative sharpens");
  o.detector.refine_edges = boolean_or("refine_edges", o.detector.refine_edges);
  o.detector.decode_sharpening = number_or("sharpening", o.detector.decode_sharpening, 0, 10, "0 to 10; 0.25 is the default");
  o.detector.min_contrast = integer_or("min_contrast", o.detector.min_contrast, 0, 255,
                                      "0 to 255 grey levels; tiles flatter than this are skipped (default 10)");
  o.detector.threads = integer_or("threads", o.detector.threads, 1, 64, "1 to 64 detector threads");
  o.detector.max_hamming = integer_or("max_hamming", o.detector.max_hamming, 0, 3, "0 to 3 corrected bit errors");
  o.detector.min_decision_margin = number_or("min_margin", o.detector.min_decision_margin, 0, 255, "0 to 255 grey levels");
  o.pose.outlier_px = number_or("outlier_px", o.pose.outlier_px, 1e-3, 1e4, "a positive error in pixels, e.g. 4");
  o.pose.max_error_px = number_or("max_error_px", o.pose.max_error_px, 1e-3, 1e4, "a positive error in pixels, e.g. 2");
  o.pose.max_ambiguity = number_or("max_ambiguity", o.pose.max_ambiguity, 0, 1, "a ratio from 0 to 1, e.g. 0.5");
  o.pose.distinct_deg = number_or("distinct_deg", o.pose.distinct_deg, 1e-3, 90, "a positive angle in degrees, e.g. 1");
  o.pose.distant_tag_px = number_or("distant_tag_px", o.pose.distant_tag_px, 0, 1e4, "an edge length in pixels, e.g. 40");
  o.max_age = number_or("max_age", o.max_age, 0, 3600, "seconds a pose stays valid without a new solve, e.g. 0.5");
  o.accept_ambiguous = boolean_or("accept_ambiguous", o.accept_ambiguous);
  o.accept_single_distant = boolean_or("accept_single_distant", o.accept_single_distant);
  if (const YAML::Node cameras = Reader::optional(node, "cameras"); cameras.IsDefined()) {
    const std::string value = cameras.IsScalar() ? cameras.Scalar() : std::string();
    if (value == "left") {
      o.stereo_cameras = StereoCameras::Left;
    } else if (value == "right") {
      o.stereo_cameras = StereoCameras::Right;
    } else if (value == "both") {
      o.stereo_cameras = StereoCameras::Both;
    } else {
      r.fail(cameras, "pose.cameras", "'" + value + "' is not a camera of a stereo camera",
             "write left, right or both (the default; a stereo camera only, docs/tracking.md)");
    }
  }
}

}  // namespace

PoseConfig parse_pose_config(const YAML::Node& node, const fs::path& file, const fs::path& root) {
  const Reader r(file, root);
  if (!node.IsDefined() || node.IsNull()) r.fail(node, "pose", "missing", std::string("add a 'pose:' map with a kind; ") + kPoseDocs);
  if (!node.IsMap()) r.fail(node, "pose", "expected a map of fields", std::string("write 'kind: fixed' or 'kind: track' and its fields; ") + kPoseDocs);
  const std::string kind_fix =
      "write 'kind: fixed' (position and orientation or look_at), 'kind: track' (csv) or 'kind: markers' (map)";
  const YAML::Node kind_node = r.require(node, "kind", kind_fix);
  const std::string kind = kind_node.IsScalar() ? kind_node.Scalar() : std::string();

  PoseConfig config;
  config.file = file;
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
    config.csv = r.path(csv, "pose.csv", csv_fix);
  } else if (kind == "markers") {
    r.check_keys(node, kMarkerKeys);
    config.kind = PoseConfig::Kind::Markers;
    parse_markers(r, node, config);
  } else {
    r.fail(kind_node, "pose.kind", "unknown kind '" + kind + "'", unknown_key_fix(kind, std::span<const std::string_view>(kPoseKinds)));
  }
  return config;
}

PoseConfig load_pose_config(const fs::path& file) {
  YamlReader reader(file);
  const YAML::Node root = reader.parse(read_file(file));
  if (!root.IsMap()) {
    throw InputError(input_message(file, -1, -1, "pose", "the file has no top-level map",
                                   std::string("write 'pose:' with a kind and its fields; ") + kPoseDocs));
  }
  reader.read_root(root);
  return parse_pose_config(root["pose"], file, reader.root());
}

std::unique_ptr<PoseSource> open_pose_source(const PoseConfig& config) {
  if (config.kind == PoseConfig::Kind::Markers) {
    throw InputError(input_message(config.file, -1, -1, "pose.kind",
                                   "the marker tracker needs the HMD camera's frames, which this program does not take",
                                   "run skylit-live with this config, or use 'kind: fixed' or 'kind: track' here "
                                   "(docs/tracking.md)"));
  }
  if (config.kind == PoseConfig::Kind::Track) return std::make_unique<PoseTrack>(PoseTrack::load(config.csv));
  return std::make_unique<FixedPose>(config.fixed);
}

}  // namespace skylit::track
