// The marker map's YAML: reading with errors a user can act on, and writing.
#include "skylit/track/marker_map.hpp"

#include <array>
#include <cmath>
#include <map>
#include <span>
#include <stdexcept>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/base/yaml_writer.hpp"
#include "skylit/track/tag_detector.hpp"

namespace skylit::track {
namespace {

namespace fs = std::filesystem;

constexpr std::array<std::string_view, 3> kTopKeys{"family", "size", "tags"};
constexpr std::array<std::string_view, 5> kTagKeys{"id", "size", "position", "orientation", "R"};
constexpr double kRotationTolerance = 1e-3;
const char* const kMarkerMapDocs = "see docs/tracking.md (marker map)";

int family_size(const YamlReader& r, const YAML::Node& node, const std::string& family) {
  try {
    return tag_family_layout(family).ncodes;
  } catch (const std::invalid_argument&) {
    r.fail(node, "family", "unknown AprilTag family '" + family + "'", unknown_key_fix(family, tag_families()));
  }
}

Eigen::Quaterniond read_rotation(const YamlReader& r, const YAML::Node& tag, const std::string& prefix) {
  const YAML::Node orientation = YamlReader::optional(tag, "orientation");
  const YAML::Node matrix = YamlReader::optional(tag, "R");
  const std::string fix =
      "give 'orientation: [qw, qx, qy, qz]' (R_site_from_tag, unit length) or 'R: [9 numbers]' (row-major); " +
      std::string(kMarkerMapDocs);
  if (orientation.IsDefined() == matrix.IsDefined()) {
    r.fail(orientation.IsDefined() ? orientation : tag, prefix + "orientation",
           orientation.IsDefined() ? "both orientation and R are given" : "neither orientation nor R is given", fix);
  }
  if (orientation.IsDefined()) {
    const auto q = r.numbers(orientation, 4, prefix + "orientation", fix);
    const Eigen::Quaterniond quaternion(q[0], q[1], q[2], q[3]);
    if (std::abs(quaternion.norm() - 1.0) > kRotationTolerance) {
      r.fail(orientation, prefix + "orientation", "the quaternion's length is " + format_number(quaternion.norm()) + ", not 1",
             "write a unit quaternion qw, qx, qy, qz, e.g. [1, 0, 0, 0] for a tag lying face up, its top towards north");
    }
    return quaternion.normalized();
  }
  const auto v = r.numbers(matrix, 9, prefix + "R", fix);
  Eigen::Matrix3d R;
  R << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > kRotationTolerance || R.determinant() < 0) {
    r.fail(matrix, prefix + "R",
           R.determinant() < 0 ? "not a rotation (its determinant is negative: a mirror)"
                               : "not a rotation (Rᵀ·R differs from the identity by " + format_number(orthogonality) + ")",
           "write R_site_from_tag row-major: its columns are the tag's x (right), y (up) and z (out of the face) in the "
           "site frame");
  }
  // The nearest rotation (polar decomposition through the SVD) absorbs rounding in the file.
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return Eigen::Quaterniond(Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose())).normalized();
}

void check_map(const MarkerMap& map) {
  const auto fail = [&](const std::string& field, const std::string& problem, const std::string& fix) {
    throw InputError(input_message(map.file, -1, -1, field, problem, fix));
  };
  int ncodes = 0;
  try {
    ncodes = tag_family_layout(map.family).ncodes;
  } catch (const std::invalid_argument&) {
    fail("family", "unknown AprilTag family '" + map.family + "'", unknown_key_fix(map.family, tag_families()));
  }
  std::map<int, std::size_t> seen;
  for (std::size_t i = 0; i < map.tags.size(); ++i) {
    const MarkerTag& tag = map.tags[i];
    const std::string prefix = "tags[" + std::to_string(i) + "].";
    if (tag.id < 0 || tag.id >= ncodes) {
      fail(prefix + "id", std::to_string(tag.id) + " is outside " + map.family + " (0.." + std::to_string(ncodes - 1) + ")",
           "use the id printed with the tag");
    }
    if (!seen.emplace(tag.id, i).second) {
      fail(prefix + "id", "id " + std::to_string(tag.id) + " appears twice", "give each tag on the site its own id");
    }
    if (!(tag.size > 0) || !std::isfinite(tag.size)) fail(prefix + "size", "must be positive", "write the edge length in metres");
    if (!tag.t_site_from_tag.allFinite()) fail(prefix + "position", "not finite", "write the tag centre in metres");
    if (!tag.R_site_from_tag.coeffs().allFinite() || std::abs(tag.R_site_from_tag.norm() - 1.0) > kRotationTolerance) {
      fail(prefix + "orientation", "not a unit quaternion", "write a unit quaternion qw, qx, qy, qz");
    }
  }
}

}  // namespace

const MarkerTag* MarkerMap::find(int id) const {
  for (const MarkerTag& tag : tags) {
    if (tag.id == id) return &tag;
  }
  return nullptr;
}

Eigen::Vector3d tag_corner_in_tag(double size, int k) {
  const double h = size / 2;
  switch (k & 3) {
    case 0: return {-h, -h, 0};
    case 1: return {h, -h, 0};
    case 2: return {h, h, 0};
    default: return {-h, h, 0};
  }
}

std::array<Eigen::Vector3d, 4> tag_corners_in_site(const MarkerTag& tag) {
  std::array<Eigen::Vector3d, 4> corners;
  for (int k = 0; k < 4; ++k) {
    corners[static_cast<std::size_t>(k)] = tag.R_site_from_tag * tag_corner_in_tag(tag.size, k) + tag.t_site_from_tag;
  }
  return corners;
}

MarkerMap load_marker_map(const fs::path& file) {
  const YamlReader r(file);
  const YAML::Node root = r.load();
  r.expect_map(root, "", std::string("write 'family:' and 'tags:' at the top level; ") + kMarkerMapDocs);
  r.check_keys(root, "", kTopKeys);
  MarkerMap map;
  map.file = file;
  const YAML::Node family_node = r.require(root, "family", "family", "the AprilTag family of the printed tags, e.g. 'family: tag36h11'");
  map.family = r.text(family_node, "family", "the AprilTag family of the printed tags, e.g. 'family: tag36h11'");
  const int ncodes = family_size(r, family_node, map.family);

  const std::string size_fix = "write the edge of the tag's black square in metres, e.g. 'size: 0.20'";
  std::optional<double> default_size;
  if (const YAML::Node size = YamlReader::optional(root, "size")) default_size = r.positive(size, "size", size_fix);

  const YAML::Node tags = r.require(root, "tags", "tags", "a list of tags with id, size, position and orientation");
  if (!tags.IsSequence()) r.fail(tags, "tags", "expected a list of tags", std::string("write '- id: 0' entries; ") + kMarkerMapDocs);
  if (tags.size() == 0) r.fail(tags, "tags", "the list is empty", std::string("add the tags placed on the site; ") + kMarkerMapDocs);
  std::map<int, int> lines;  // id → line of its first entry, for the duplicate message
  for (std::size_t i = 0; i < tags.size(); ++i) {
    const YAML::Node tag = tags[i];
    const std::string prefix = "tags[" + std::to_string(i) + "].";
    r.expect_map(tag, "tags[" + std::to_string(i) + "]", std::string("write id, size, position and orientation; ") + kMarkerMapDocs);
    r.check_keys(tag, prefix, kTagKeys);
    MarkerTag entry;
    const YAML::Node id = r.require(tag, "id", prefix + "id", "the number printed with the tag");
    entry.id = static_cast<int>(r.integer(id, prefix + "id", 0, ncodes - 1,
                                          "use an id of family " + map.family + " (0.." + std::to_string(ncodes - 1) + ")"));
    const auto [first, inserted] = lines.emplace(entry.id, id.Mark().line + 1);
    if (!inserted) {
      r.fail(id, prefix + "id", "id " + std::to_string(entry.id) + " is already used at line " + std::to_string(first->second),
             "give each tag on the site its own id (one tag per id)");
    }
    if (const YAML::Node size = YamlReader::optional(tag, "size")) {
      entry.size = r.positive(size, prefix + "size", size_fix);
    } else if (default_size) {
      entry.size = *default_size;
    } else {
      r.fail(tag, prefix + "size", "required field is missing (and no map-wide 'size' is given)", "add it: " + size_fix);
    }
    const std::string position_fix = "write the tag centre in the site frame (x east, y north, z up), metres, e.g. [0, 3, 1.5]";
    const auto p = r.numbers(r.require(tag, "position", prefix + "position", position_fix), 3, prefix + "position", position_fix);
    entry.t_site_from_tag = Eigen::Vector3d(p[0], p[1], p[2]);
    entry.R_site_from_tag = read_rotation(r, tag, prefix);
    map.tags.push_back(entry);
  }
  return map;
}

std::string marker_map_to_yaml(const MarkerMap& map) {
  using YAML::Key, YAML::Value;
  YAML::Emitter out;
  out << YamlCommentLine{"skylit marker map (format: docs/tracking.md). Site frame: x east, y north, z up, metres.\n"
                         "Tag frame: x right, y up as printed, z out of the face; orientation = R_site_from_tag."}
      << YAML::BeginMap << Key << "family" << Value << map.family << Key << "tags" << Value << YAML::BeginSeq;
  for (const MarkerTag& tag : map.tags) {
    const Eigen::Quaterniond& q = tag.R_site_from_tag;
    const std::array<double, 4> wxyz{q.w(), q.x(), q.y(), q.z()};
    out << YAML::BeginMap << Key << "id" << Value << tag.id << Key << "size" << Value << YamlNumber{tag.size}
        << Key << "position" << Value << YamlNumbers{std::span<const double>(tag.t_site_from_tag.data(), 3)}
        << Key << "orientation" << Value << YamlNumbers{wxyz} << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return yaml_document(out);
}

void save_marker_map(const MarkerMap& map, const fs::path& file) {
  check_map(map);
  write_file_atomic(file, marker_map_to_yaml(map));
}

}  // namespace skylit::track
