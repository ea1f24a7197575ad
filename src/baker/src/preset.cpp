#include "skylit/baker/preset.hpp"

#include <array>
#include <string_view>

namespace skylit::baker {
namespace {

constexpr std::array<std::string_view, 12> kKeys{"frequency",  "basis",     "samples",           "pca_components",
                                                 "pca_tile",   "refine",    "vertex_fit",        "light_map",
                                                 "light_map_min_area", "light_map_min_across", "light_map_components",
                                                 "light_map_pca_only"};
constexpr std::array<std::string_view, 3> kBases{"faces", "corners", "quadratics"};

}  // namespace

BakePreset load_bake_preset(const PresetsFile& presets, const std::string& name) {
  const PresetSection s = presets.section(name, "bake");
  const YamlReader& r = s.reader;
  r.check_keys(s.node, s.field + ".", kKeys);
  BakePreset p;
  p.name = name;
  const YAML::Node frequency = r.require(s.node, "frequency", s.field_of("frequency"), "an even dome frequency, e.g. 2");
  p.frequency = static_cast<int>(r.integer(frequency, s.field_of("frequency"), 1, 64, "an even dome frequency, e.g. 2"));
  if (p.frequency % 2 != 0) r.fail(frequency, s.field_of("frequency"), "must be even", "e.g. 2 or 4");
  const std::string basis =
      r.choice(r.require(s.node, "basis", s.field_of("basis"), "faces, corners or quadratics"), s.field_of("basis"), kBases);
  p.basis = *geom::parse_basis(basis);
  p.samples = static_cast<int>(r.integer(r.require(s.node, "samples", s.field_of("samples"), "samples per face, e.g. 16"),
                                         s.field_of("samples"), 1, 4096, "samples per face, e.g. 16"));
  if (auto n = YamlReader::optional(s.node, "pca_components")) {
    p.pca_components = static_cast<int>(
        r.integer(n, s.field_of("pca_components"), 0, 4096, "principal components stored, 0 for none"));
  }
  if (auto n = YamlReader::optional(s.node, "pca_tile")) {
    p.pca_tile = static_cast<int>(r.integer(n, s.field_of("pca_tile"), 0, 1 << 20,
                                            "texels per side of a clustered-PCA tile, 0 for one set per plane"));
    if (p.pca_tile == 1) r.fail(n, s.field_of("pca_tile"), "a tile holds at least 2 × 2 texels", "use 0 or e.g. 64");
  }
  if (auto n = YamlReader::optional(s.node, "refine")) {
    p.refine = r.non_negative(n, s.field_of("refine"), "a share of E_h, e.g. 0.2 (skylit-bake --refine), or 0 for none");
  }
  if (auto n = YamlReader::optional(s.node, "vertex_fit")) {
    p.vertex_fit = static_cast<int>(
        r.integer(n, s.field_of("vertex_fit"), 0, 16, "points per triangle side of the vertex fit, e.g. 3 (skylit-bake --vertex-fit), or 0"));
  }
  if (auto n = YamlReader::optional(s.node, "light_map")) {
    p.light_map = r.non_negative(n, s.field_of("light_map"), "metres per texel, e.g. 0.1 (skylit-bake --light-map), or 0 for none");
  }
  bool light_map_keys = false;  // any of the light map's other keys
  if (auto n = YamlReader::optional(s.node, "light_map_min_area")) {
    p.light_map_min_area = r.non_negative(n, s.field_of("light_map_min_area"), "m², e.g. 0.1 (skylit-bake --light-map-min-area)");
    light_map_keys = true;
  }
  if (auto n = YamlReader::optional(s.node, "light_map_min_across")) {
    p.light_map_min_across = static_cast<int>(r.integer(n, s.field_of("light_map_min_across"), 1, 1024,
                                                        "texels across a narrow chart, e.g. 10 (skylit-bake --light-map-min-across)"));
    light_map_keys = true;
  }
  if (auto n = YamlReader::optional(s.node, "light_map_components")) {
    p.light_map_components = static_cast<int>(r.integer(n, s.field_of("light_map_components"), 0, 4096,
                                                        "components of the light map's PCA form, e.g. 32, or 0 for the full form only"));
    light_map_keys = true;
  }
  if (auto n = YamlReader::optional(s.node, "light_map_pca_only")) {
    p.light_map_pca_only = r.boolean(n, s.field_of("light_map_pca_only"), "true or false (skylit-bake --light-map-pca-only)");
    light_map_keys = true;
    if (p.light_map_pca_only && p.light_map_components == 0) {
      r.fail(n, s.field_of("light_map_pca_only"), "needs the PCA form", "add e.g. light_map_components: 32, or remove it");
    }
  }
  if (p.light_map == 0 && light_map_keys) {
    r.fail(s.node, s.field_of("light_map"), "the light map's other keys need a light map", "add e.g. light_map: 0.1, or remove them");
  }
  return p;
}

}  // namespace skylit::baker
