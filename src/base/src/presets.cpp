#include "skylit/base/presets.hpp"

#include <array>
#include <string_view>

#include "skylit/base/error.hpp"
#include "skylit/base/yaml_reader.hpp"

namespace skylit {
namespace {

constexpr const char* kDocs = "see docs/presets.md";
constexpr std::array<std::string_view, 2> kPresetKeys{"bake", "live"};
constexpr std::array<std::string_view, 5> kBakeKeys{"frequency", "basis", "samples", "pca_components", "pca_tile"};
constexpr std::array<std::string_view, 7> kLiveKeys{"basis", "storage", "skip_threshold", "change_threshold",
                                                   "smoothing", "sun", "render_scale"};
constexpr std::array<std::string_view, 3> kBases{"faces", "corners", "quadratics"};
constexpr std::array<std::string_view, 4> kForms{"full", "lean", "pca", "cropped"};
constexpr std::array<std::string_view, 3> kStorages{"half", "unorm8", "eac"};
constexpr std::array<std::string_view, 2> kSunModes{"auto", "off"};

}  // namespace

std::filesystem::path default_presets_file() { return SKYLIT_DEFAULT_PRESETS_FILE; }

std::vector<Preset> load_presets(const std::filesystem::path& file) {
  const YamlReader r(file);
  const YAML::Node root = r.load();
  r.expect_map(root, "", "a presets file maps each name to {bake: {...}, live: {...}}; " + std::string(kDocs));
  std::vector<Preset> presets;
  for (const auto& entry : root) {
    Preset p;
    p.name = entry.first.as<std::string>();
    const YAML::Node node = entry.second;
    const std::string at = p.name + ".";
    r.expect_map(node, p.name, "{bake: {...}, live: {...}}; " + std::string(kDocs));
    r.check_keys(node, at, kPresetKeys);
    const YAML::Node bake = r.require(node, "bake", at + "bake", "the bake's settings: frequency, basis, samples");
    r.expect_map(bake, at + "bake", kDocs);
    r.check_keys(bake, at + "bake.", kBakeKeys);
    p.bake.frequency = static_cast<int>(
        r.integer(r.require(bake, "frequency", at + "bake.frequency", "an even dome frequency, e.g. 2"),
                  at + "bake.frequency", 1, 64, "an even dome frequency, e.g. 2"));
    if (p.bake.frequency % 2 != 0) r.fail(bake["frequency"], at + "bake.frequency", "must be even", "e.g. 2 or 4");
    p.bake.basis = r.choice(r.require(bake, "basis", at + "bake.basis", "faces, corners or quadratics"), at + "bake.basis", kBases);
    p.bake.samples = static_cast<int>(r.integer(r.require(bake, "samples", at + "bake.samples", "samples per face, e.g. 16"),
                                                at + "bake.samples", 1, 4096, "samples per face, e.g. 16"));
    if (auto n = YamlReader::optional(bake, "pca_components")) {
      p.bake.pca_components = static_cast<int>(r.integer(n, at + "bake.pca_components", 0, 4096,
                                                         "principal components stored, 0 for none"));
    }
    if (auto n = YamlReader::optional(bake, "pca_tile")) {
      p.bake.pca_tile = static_cast<int>(r.integer(n, at + "bake.pca_tile", 0, 1 << 20,
                                                   "texels per side of a clustered-PCA tile, 0 for one set per plane"));
      if (p.bake.pca_tile == 1) {
        r.fail(bake["pca_tile"], at + "bake.pca_tile", "a tile holds at least 2 × 2 texels", "use 0 or e.g. 64");
      }
    }
    const YAML::Node live = r.require(node, "live", at + "live", "the live service's settings");
    r.expect_map(live, at + "live", kDocs);
    r.check_keys(live, at + "live.", kLiveKeys);
    if (auto n = YamlReader::optional(live, "basis")) p.live.basis = r.choice(n, at + "live.basis", kForms);
    if (auto n = YamlReader::optional(live, "storage")) p.live.storage = r.choice(n, at + "live.storage", kStorages);
    if (auto n = YamlReader::optional(live, "skip_threshold")) {
      p.live.skip_threshold = r.non_negative(n, at + "live.skip_threshold", "T units, e.g. 0.002");
    }
    if (auto n = YamlReader::optional(live, "change_threshold")) {
      p.live.change_threshold = r.non_negative(n, at + "live.change_threshold", "T units, e.g. 0.002");
    }
    if (auto n = YamlReader::optional(live, "smoothing")) p.live.smoothing = r.non_negative(n, at + "live.smoothing", "seconds");
    if (auto n = YamlReader::optional(live, "sun")) p.live.sun = r.choice(n, at + "live.sun", kSunModes) == "auto";
    if (auto n = YamlReader::optional(live, "render_scale")) {
      p.live.render_scale = r.positive(n, at + "live.render_scale", "the building's render scale in (0, 1], e.g. 0.75");
      if (p.live.render_scale > 1.0) r.fail(n, at + "live.render_scale", "is over 1", "a scale in (0, 1], e.g. 0.75");
    }
    if (p.live.basis == "pca" && p.bake.pca_components == 0) {
      r.fail(live["basis"], at + "live.basis", "pca needs a PCA form in the bake, and bake.pca_components is 0",
             "set bake.pca_components (e.g. 8), or live.basis: full");
    }
    if (p.live.basis == "pca" && p.live.storage != "half") {
      r.fail(live["storage"], at + "live.storage", p.live.storage + " cannot hold the PCA form's eigen-images", "storage: half");
    }
    presets.push_back(std::move(p));
  }
  if (presets.empty()) r.fail(root, "", "no presets", "name at least one, e.g. balanced: {bake: ..., live: ...}");
  return presets;
}

std::string preset_names(const std::vector<Preset>& presets) {
  std::string names;
  for (const Preset& p : presets) names += (names.empty() ? "" : ", ") + p.name;
  return names;
}

Preset find_preset(const std::filesystem::path& file, const std::string& name) {
  const std::vector<Preset> presets = load_presets(file);
  for (const Preset& p : presets) {
    if (p.name == name) return p;
  }
  throw InputError("preset '" + name + "' is not in " + file.string() + ". Fix: use one of " + preset_names(presets));
}

}  // namespace skylit
