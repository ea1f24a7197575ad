// HMD profiles from YAML (see hmd_profile.hpp and docs/hmd.md).
#include "skylit/render/hmd_profile.hpp"

#include <algorithm>
#include <cstdio>
#include <string_view>

#include "skylit/base/yaml_reader.hpp"

namespace skylit::render {

namespace {

constexpr std::string_view kTopKeys[] = {"name", "panel", "layout", "ipd", "fov_deg", "lens"};
constexpr std::string_view kPanelKeys[] = {"width", "height"};
constexpr std::string_view kLensKeys[] = {"left_center", "right_center", "center", "radius", "red", "green", "blue"};
constexpr std::string_view kLayouts[] = {"single", "side-by-side"};

RadialDistortion read_channel(const YamlReader& reader, const YAML::Node& lens, const std::string& key) {
  const YAML::Node node = YamlReader::optional(lens, key);
  if (!node.IsDefined()) return {};
  const std::vector<double> k = reader.numbers(node, 3, "lens." + key, "write [k1, k2, k3] (0 for none)");
  return {k[0], k[1], k[2]};
}

}  // namespace

HmdProfile load_hmd_profile(const std::filesystem::path& file) {
  const YamlReader reader(file);
  const YAML::Node root = reader.load();
  reader.expect_map(root, "(top level)", "write the profile as a map: name, panel, layout, ipd, fov_deg, lens");
  reader.check_keys(root, "", kTopKeys);

  HmdProfile profile;
  profile.file = file;
  profile.name = reader.text(reader.require(root, "name", "name", "name: a name for the log"), "name", "a text");

  const YAML::Node panel = reader.require(root, "panel", "panel", "panel: {width: PIXELS, height: PIXELS}");
  reader.expect_map(panel, "panel", "write panel: {width: PIXELS, height: PIXELS}");
  reader.check_keys(panel, "panel.", kPanelKeys);
  const std::string size_fix = "the panel's size in pixels, both eyes together (e.g. 3840 × 1080)";
  profile.panel_width = static_cast<int>(
      reader.integer(reader.require(panel, "width", "panel.width", size_fix), "panel.width", 16, 16384, size_fix));
  profile.panel_height = static_cast<int>(
      reader.integer(reader.require(panel, "height", "panel.height", size_fix), "panel.height", 16, 16384, size_fix));

  const YAML::Node layout = reader.require(root, "layout", "layout", "layout: single (a monitor) or side-by-side (an HMD)");
  profile.layout = reader.choice(layout, "layout", kLayouts) == "single" ? PanelLayout::single : PanelLayout::side_by_side;
  if (profile.layout == PanelLayout::side_by_side && profile.panel_width % 2 != 0) {
    reader.fail(panel, "panel.width", "an odd width cannot be split between two eyes", "give the panel's even width");
  }

  if (const YAML::Node ipd = YamlReader::optional(root, "ipd"); ipd.IsDefined()) {
    profile.ipd = reader.non_negative(ipd, "ipd", "the distance between the eyes in metres (typically 0.058 to 0.070)");
    if (profile.ipd > 0.1) {
      reader.fail(ipd, "ipd", "more than 0.1 m between the eyes", "give it in metres (0.064, not 64)");
    }
  }
  if (const YAML::Node fov = YamlReader::optional(root, "fov_deg"); fov.IsDefined()) {
    profile.fov_deg = reader.positive(fov, "fov_deg", "the horizontal field of view of one eye in degrees");
    if (profile.fov_deg >= 180) reader.fail(fov, "fov_deg", "must be below 180°", "give one eye's horizontal field of view");
  }

  const int eye_width = profile.eye_width(), eye_height = profile.eye_height();
  const Eigen::Vector2d middle(eye_width / 2.0, eye_height / 2.0);
  profile.lens_center = {middle, middle};
  profile.lens_radius = eye_width / 2.0;
  if (const YAML::Node lens = YamlReader::optional(root, "lens"); lens.IsDefined()) {
    reader.expect_map(lens, "lens", "write lens: {left_center, right_center, radius, red, green, blue}");
    reader.check_keys(lens, "lens.", kLensKeys);
    const std::string centre_fix = "[x, y] in pixels of the eye's viewport (" + std::to_string(eye_width) + " × " +
                                   std::to_string(eye_height) + "), from its top-left corner";
    auto read_center = [&](const std::string& key, int eye) {
      const YAML::Node node = YamlReader::optional(lens, key);
      if (!node.IsDefined()) return;
      const std::vector<double> c = reader.numbers(node, 2, "lens." + key, centre_fix);
      if (c[0] < 0 || c[0] > eye_width || c[1] < 0 || c[1] > eye_height) {
        reader.fail(node, "lens." + key, "the centre lies outside the eye's viewport", centre_fix);
      }
      profile.lens_center[static_cast<std::size_t>(eye)] = Eigen::Vector2d(c[0], c[1]);
    };
    if (profile.layout == PanelLayout::single) {
      if (YamlReader::optional(lens, "left_center").IsDefined() || YamlReader::optional(lens, "right_center").IsDefined()) {
        reader.fail(lens, "lens", "left_center and right_center are for the side-by-side layout",
                    "write center: [x, y] for a single image");
      }
      read_center("center", 0);
      profile.lens_center[1] = profile.lens_center[0];
    } else {
      if (YamlReader::optional(lens, "center").IsDefined()) {
        reader.fail(lens, "lens.center", "a side-by-side panel has one lens per eye",
                    "write left_center and right_center");
      }
      read_center("left_center", 0);
      read_center("right_center", 1);
    }
    if (const YAML::Node radius = YamlReader::optional(lens, "radius"); radius.IsDefined()) {
      profile.lens_radius = reader.positive(radius, "lens.radius", "the distance in pixels from the lens centre where r = 1");
    }
    profile.distortion = {read_channel(reader, lens, "red"), read_channel(reader, lens, "green"),
                          read_channel(reader, lens, "blue")};
    // The mapping must move outwards all the way to the farthest corner of an eye's viewport:
    // where ρ·(1 + k1 ρ² + k2 ρ⁴ + k3 ρ⁶) turns back, the mesh would fold over itself.
    double farthest = 0;
    for (int eye = 0; eye < profile.eye_count(); ++eye) {
      const Eigen::Vector2d c = profile.lens_center[static_cast<std::size_t>(eye)];
      for (const Eigen::Vector2d& corner : {Eigen::Vector2d(0, 0), Eigen::Vector2d(eye_width, 0),
                                           Eigen::Vector2d(0, eye_height), Eigen::Vector2d(eye_width, eye_height)}) {
        farthest = std::max(farthest, (corner - c).norm() / profile.lens_radius);
      }
    }
    const char* names[3] = {"red", "green", "blue"};
    for (std::size_t ch = 0; ch < 3; ++ch) {
      const RadialDistortion& k = profile.distortion[ch];
      for (int i = 1; i <= 1000; ++i) {
        const double rho = farthest * i / 1000.0, r2 = rho * rho;
        const double slope = 1 + 3 * k.k1 * r2 + 5 * k.k2 * r2 * r2 + 7 * k.k3 * r2 * r2 * r2;  // d/dρ of ρ·scale(ρ²)
        if (slope <= 0) {
          char at[64];
          std::snprintf(at, sizeof at, "%.2f", rho);
          reader.fail(lens[names[ch]], std::string("lens.") + names[ch],
                      std::string("the distortion turns back at r = ") + at + " (inside the panel, up to r = " +
                          std::to_string(farthest).substr(0, 4) + "): the image would fold over",
                      "check the signs and sizes of k1, k2, k3 (and lens.radius)");
        }
      }
    }
  }
  return profile;
}

}  // namespace skylit::render
