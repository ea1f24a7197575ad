#pragma once
// A marker map: where the AprilTags placed on a site are (docs/tracking.md).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace skylit::track {

// The tag frame: origin at the tag's centre, x to the right and y up as the tag is printed and
// seen from the front, z out of the printed face towards the viewer. Identity = the tag lying on
// the ground face up, its top edge towards north. Corners, in this order (libapriltag's):
//   0 = (−s/2, −s/2, 0) bottom-left, 1 = (s/2, −s/2, 0) bottom-right,
//   2 = (s/2, s/2, 0) top-right,     3 = (−s/2, s/2, 0) top-left.
struct MarkerTag {
  int id = 0;
  double size = 0;  // metres
  Eigen::Quaterniond R_site_from_tag = Eigen::Quaterniond::Identity();
  Eigen::Vector3d t_site_from_tag = Eigen::Vector3d::Zero();  // the tag's centre
};

// A marker map file (YAML):
//
//   family: tag36h11              # libapriltag's family name
//   size: 0.20                    # optional default edge length for the tags below, metres
//   tags:
//     - id: 0
//       size: 0.20                # edge of the black square whose corners are detected, metres
//       position: [0, 3, 1.5]     # the tag's centre in the site frame (x east, y north, z up)
//       orientation: [qw, qx, qy, qz]   # R_site_from_tag, unit quaternion
//       # or, instead of orientation:
//       R: [r00, r01, r02, r10, r11, r12, r20, r21, r22]   # R_site_from_tag, row-major
struct MarkerMap {
  std::filesystem::path file;  // where it came from (messages); may be empty
  std::string family = "tag36h11";
  std::vector<MarkerTag> tags;  // ids unique

  const MarkerTag* find(int id) const;
};

// Corner k of a tag in its own frame (the order above).
Eigen::Vector3d tag_corner_in_tag(double size, int k);
// The four corners of a tag in the site frame.
std::array<Eigen::Vector3d, 4> tag_corners_in_site(const MarkerTag& tag);

// Reads the YAML above. InputError naming the file, line, column and field (with the fix) for
// anything missing, unknown or wrong: an unknown family, an id outside the family, a duplicate
// id, a size that is not positive, a quaternion that is not unit length (within 1e-3, then
// normalised), an R that is not a rotation (within 1e-3, then orthonormalised).
MarkerMap load_marker_map(const std::filesystem::path& file);
// The map as YAML (the quaternion form, full precision); load_marker_map reads it back exactly.
std::string marker_map_to_yaml(const MarkerMap& map);
// Checks the map (as load does; InputError naming map.file) and writes it atomically.
void save_marker_map(const MarkerMap& map, const std::filesystem::path& file);

}  // namespace skylit::track
