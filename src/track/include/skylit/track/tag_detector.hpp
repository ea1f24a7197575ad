#pragma once
// AprilTag detection (Debian's libapriltag, hidden behind this header).
#include <array>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "skylit/track/marker_options.hpp"

namespace cv {
class Mat;
}

namespace skylit::track {

// Corners are in OpenCV's pixel convention (pixel centres at integers; libapriltag puts them at
// +0.5, which is undone here) and in the marker map's corner order (docs/tracking.md): as the
// tag is printed and seen from the front, 0 = bottom-left, 1 = bottom-right, 2 = top-right,
// 3 = top-left (libapriltag's order: counter-clockwise on the page).
struct TagDetection {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners;  // pixels, the order above
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // the homography's image of the tag centre
  double decision_margin = 0;  // mean distance of the bits from the threshold (grey levels)
  int hamming = 0;             // bit errors corrected
};

// The families libapriltag ships, by name.
std::span<const std::string_view> tag_families();

// Geometry of a family's printed tag, in cells: `width_at_border` is the edge of the square whose
// corners are detected (the tag's size in a marker map), `total_width` the whole printed pattern
// (tag36h11: 8 and 10, the outer cells a white border).
struct TagFamilyLayout {
  int width_at_border = 0;
  int total_width = 0;
  int ncodes = 0;
  bool reversed_border = false;
};
// std::invalid_argument for an unknown family (naming the known ones).
TagFamilyLayout tag_family_layout(std::string_view family);
// The printed pattern of tag `id`: total_width × total_width cells, row 0 at the top, 0 black and
// 255 white (the layout of libapriltag's apriltag_to_image, drawn from the family's codes). std::out_of_range for an id outside the family.
std::vector<unsigned char> tag_pattern(std::string_view family, int id);

// One detector for one family; not safe to call from two threads at once (use one per thread).
class TagDetector {
 public:
  // std::invalid_argument for an unknown family or options out of range, and when the decode
  // table for max_hamming would be too large (the message says which max_hamming fits).
  explicit TagDetector(const TagDetectorOptions& options = {});
  ~TagDetector();
  TagDetector(const TagDetector&) = delete;
  TagDetector& operator=(const TagDetector&) = delete;
  TagDetector(TagDetector&&) noexcept;
  TagDetector& operator=(TagDetector&&) noexcept;

  // Tags in an 8-bit grey (CV_8UC1) or BGR (CV_8UC3) frame, by increasing id.
  // std::invalid_argument for other types.
  std::vector<TagDetection> detect(const cv::Mat& frame);

  const TagDetectorOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace skylit::track
