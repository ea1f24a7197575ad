#pragma once
// An HMD's display: its panel, how the panel is split between the eyes, the distance between the
// eyes, and the radial distortion of its lenses per colour channel (config/hmd/*.yaml,
// docs/hmd.md). The distortion maps a panel pixel to the point of the eye image it must show.
#include <array>
#include <filesystem>
#include <string>

#include <Eigen/Core>

namespace skylit::render {

enum class PanelLayout {
  single,        // one image over the whole panel (a desktop monitor, or a mono HMD)
  side_by_side,  // left eye on the left half, right eye on the right half
};

// The lens of one colour channel: a panel point at normalised radius r from the lens centre shows
// the eye image at (1 + k1 r² + k2 r⁴ + k3 r⁶) times its offset from the centre.
struct RadialDistortion {
  double k1 = 0;
  double k2 = 0;
  double k3 = 0;
  double scale(double r2) const { return 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)); }
  bool identity() const { return k1 == 0 && k2 == 0 && k3 == 0; }
};

struct HmdProfile {
  std::filesystem::path file;  // where it was read from (for messages)
  std::string name;
  int panel_width = 1280;      // pixels, the whole panel (both eyes)
  int panel_height = 720;
  PanelLayout layout = PanelLayout::single;
  double ipd = 0.064;          // m, between the eyes' centres
  double fov_deg = 90;         // horizontal field of view of one eye through its lens
  // Lens centre of each eye (left, right), in pixels of the eye's viewport from its top-left
  // corner (for the single layout only the first is used).
  std::array<Eigen::Vector2d, 2> lens_center{Eigen::Vector2d(640, 360), Eigen::Vector2d(640, 360)};
  double lens_radius = 640;    // pixels: the distance from the lens centre where r = 1
  std::array<RadialDistortion, 3> distortion{};  // red, green, blue

  int eye_count() const { return layout == PanelLayout::side_by_side ? 2 : 1; }
  // The viewport of one eye on the panel: its width, its height, its left edge.
  int eye_width() const { return panel_width / eye_count(); }
  int eye_height() const { return panel_height; }
  int eye_left(int eye) const { return eye * eye_width(); }
  bool has_distortion() const {
    return !(distortion[0].identity() && distortion[1].identity() && distortion[2].identity());
  }
};

// Reads an HMD profile. InputError naming the file, the field and the fix for a missing or
// unknown field, a bad value, or a lens centre outside its eye's viewport.
HmdProfile load_hmd_profile(const std::filesystem::path& file);

}  // namespace skylit::render
