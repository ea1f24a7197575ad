#include "skylit/live/live_config.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <string_view>
#include <tuple>

#include "skylit/base/error.hpp"
#include "skylit/base/presets.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/blend/gpu_blend.hpp"
#include "skylit/sky_link/site_topics.hpp"

namespace skylit::live {
namespace {

constexpr const char* kDocs = "see docs/live.md (Configuration)";
constexpr std::array<std::string_view, 16> kTopKeys{"site",     "bake",  "preset",      "sky",    "camera", "pose",   "imu",
                                                    "fusion",   "tracking", "blend", "render", "photometric", "output", "status", "display",
                                                    "root"};
constexpr std::array<std::string_view, 6> kRenderKeys{"scale",     "ground_light",   "ground_albedo",
                                                      "light_map", "light_map_form", "light_map_precision"};
constexpr std::array<std::string_view, 11> kSkyKeys{"calibration", "source",      "response",   "rate",
                                                   "sun",         "smoothing",   "stale_after", "max_sources",
                                                   "sun_colour",  "clipped_sun_energy", "bracket"};
constexpr std::array<std::string_view, 3> kCameraKeys{"calibration", "stereo", "source"};
constexpr std::array<std::string_view, 9> kLinkKeys{"broker",   "topic",         "node", "username",   "password",
                                                    "password_file", "tls", "keepalive_s", "kind"};
constexpr std::array<std::string_view, 3> kTlsKeys{"ca_file", "cert_file", "key_file"};
constexpr const char* kSiteDocs = "see docs/site.md (Configuration)";
constexpr std::array<std::string_view, 7> kBlendKeys{"device",         "threads",          "storage",    "basis",
                                                     "skip_threshold", "change_threshold", "cull_planes"};
constexpr std::array<std::string_view, 1> kTrackingKeys{"fade_s"};
constexpr std::array<std::string_view, 3> kBlendDevices{"auto", "cpu", "gpu"};
constexpr std::array<std::string_view, 2> kRecordKeys{"path", "fps"};

BlendDevice parse_blend_device(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  const std::string device = r.choice(node, field, kBlendDevices);
  return device == "cpu" ? BlendDevice::Cpu : device == "gpu" ? BlendDevice::Gpu : BlendDevice::Auto;
}
constexpr std::array<std::string_view, 2> kPhotometricKeys{"scale", "estimate"};
constexpr std::array<std::string_view, 6> kEstimateKeys{"plane",  "region", "albedo",
                                                        "every", "shadowed_region", "shadowed_sky_visibility"};

// [s0, s1, t0, t1], a rectangle inside the plane.
std::array<double, 4> parse_region(const YamlReader& r, const YAML::Node& n, const std::string& field) {
  const auto v = r.numbers(n, 4, field, "[s0, s1, t0, t1] in 0..1 along the plane's u and v");
  if (!(0 <= v[0] && v[0] < v[1] && v[1] <= 1 && 0 <= v[2] && v[2] < v[3] && v[3] <= 1)) {
    r.fail(n, field, "not a rectangle inside the plane", "0 ≤ s0 < s1 ≤ 1 and 0 ≤ t0 < t1 ≤ 1");
  }
  return {v[0], v[1], v[2], v[3]};
}
constexpr std::array<std::string_view, 2> kOutputKeys{"record", "window"};
constexpr std::array<std::string_view, 3> kStatusKeys{"listen", "token_file", "allow_unauthenticated"};
constexpr std::array<std::string_view, 3> kDisplayKeys{"profile", "monitor", "mode"};
constexpr std::array<std::string_view, 2> kDisplayModes{"mono", "stereo"};

// render.light_map_precision, or a preset's light_map_precision: float or half.
render::LightMapPrecision light_map_precision(const YamlReader& r, const YAML::Node& n, const std::string& field) {
  constexpr std::array<std::string_view, 2> names{"float", "half"};
  return r.choice(n, field, names) == "half" ? render::LightMapPrecision::Half : render::LightMapPrecision::Float;
}

}  // namespace

LivePreset load_live_preset(const PresetsFile& presets, const std::string& name) {
  constexpr std::array<std::string_view, 9> keys{"basis",        "storage",      "skip_threshold",
                                                 "change_threshold", "smoothing", "sun",
                                                 "render_scale", "ground_light", "light_map_precision"};
  constexpr std::array<std::string_view, 2> sun_modes{"auto", "off"};
  const PresetSection s = presets.section(name, "live");
  const YamlReader& r = s.reader;
  r.check_keys(s.node, s.field + ".", keys);
  LivePreset p;
  p.name = name;
  if (auto n = YamlReader::optional(s.node, "basis")) p.basis = *blend::parse_form(r.choice(n, s.field_of("basis"), blend::kFormNames));
  if (auto n = YamlReader::optional(s.node, "storage")) {
    p.storage = *blend::parse_storage(r.choice(n, s.field_of("storage"), blend::kStorageNames));
  }
  if (auto n = YamlReader::optional(s.node, "skip_threshold")) {
    p.skip_threshold = r.non_negative(n, s.field_of("skip_threshold"), "T units, e.g. 0.002");
  }
  if (auto n = YamlReader::optional(s.node, "change_threshold")) {
    p.change_threshold = r.non_negative(n, s.field_of("change_threshold"), "T units, e.g. 0.002");
  }
  if (auto n = YamlReader::optional(s.node, "smoothing")) p.smoothing = r.non_negative(n, s.field_of("smoothing"), "seconds");
  if (auto n = YamlReader::optional(s.node, "sun")) p.sun = r.choice(n, s.field_of("sun"), sun_modes) == "auto";
  if (auto n = YamlReader::optional(s.node, "render_scale")) {
    p.render_scale = r.positive(n, s.field_of("render_scale"), "the building's render scale in (0, 1], e.g. 0.75");
    if (p.render_scale > 1.0) r.fail(n, s.field_of("render_scale"), "is over 1", "a scale in (0, 1], e.g. 0.75");
  }
  if (auto n = YamlReader::optional(s.node, "ground_light")) p.ground_light = r.boolean(n, s.field_of("ground_light"), "true or false");
  if (auto n = YamlReader::optional(s.node, "light_map_precision")) {
    p.light_map_precision = light_map_precision(r, n, s.field_of("light_map_precision"));
  }
  if (p.basis == blend::BasisForm::Pca) {
    // The PCA form is the bake's to store: its section must ask for one.
    const PresetSection bake = presets.section(name, "bake");
    const YAML::Node components = YamlReader::optional(bake.node, "pca_components");
    if (!components || r.integer(components, bake.field_of("pca_components"), 0, 4096, "components") == 0) {
      r.fail(s.node["basis"], s.field_of("basis"), "pca needs a PCA form in the bake, and bake.pca_components is 0",
             "set bake.pca_components (e.g. 8), or live.basis: full");
    }
    if (p.storage != blend::BasisStorage::Half) {
      r.fail(s.node["storage"], s.field_of("storage"),
             std::string(blend::storage_name(p.storage)) + " cannot hold the PCA form's eigen-images", "storage: half");
    }
  }
  return p;
}

std::filesystem::path presets_file_for(const std::filesystem::path& config_file) {
  const std::filesystem::path beside = config_file.parent_path() / "presets.yaml";
  return std::filesystem::is_regular_file(beside) ? beside : default_presets_file();
}

std::string blend_device_name(BlendDevice device) {
  switch (device) {
    case BlendDevice::Cpu: return "cpu";
    case BlendDevice::Gpu: return "gpu";
    case BlendDevice::Auto: break;
  }
  return "auto";
}

namespace {

void apply_preset(const YamlReader& r, const YAML::Node& root, const std::filesystem::path& file, LiveConfig& c) {
  // preset: NAME sets the live settings of a preset (config/presets.yaml, docs/presets.md); the
  // keys below override them.
  if (auto n = YamlReader::optional(root, "preset")) {
    const std::string name = r.text(n, "preset", "a preset's name, e.g. preset: balanced");
    c.presets_file = presets_file_for(file);
    const PresetsFile presets(c.presets_file);
    const auto& names = presets.names();
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      r.fail(n, "preset", "no preset '" + name + "' in " + c.presets_file.string(), "use one of " + presets.names_text());
    }
    const LivePreset preset = load_live_preset(presets, name);
    c.preset = name;
    c.sky.sun = preset.sun;
    c.sky.smoothing = preset.smoothing;
    c.blend.basis = preset.basis;
    c.blend.storage = preset.storage;
    c.render.scale = preset.render_scale;
    c.render.ground_light = preset.ground_light;
    c.render.light_map_precision = preset.light_map_precision;
    c.blend.skip_threshold = preset.skip_threshold;
    c.blend.change_threshold = preset.change_threshold;
  }
}

// `prefix` is the map's field ("link", "sky.source"); `kind` is allowed there (kind: mqtt).
LinkSettings parse_link(const YamlReader& r, const YAML::Node& node, const std::string& prefix) {
  r.expect_map(node, prefix, "{broker: HOST:PORT, topic: skylit/SITE, ...}; " + std::string(kSiteDocs));
  r.check_keys(node, prefix + ".", kLinkKeys);
  LinkSettings link;
  const YAML::Node broker = r.require(node, "broker", prefix + ".broker", "the MQTT broker, e.g. broker: 127.0.0.1:1883");
  const std::string address = r.text(broker, prefix + ".broker", "HOST:PORT, e.g. 127.0.0.1:1883");
  try {
    std::tie(link.mqtt.host, link.mqtt.port) = sky_link::parse_broker_address(address, prefix + ".broker");
  } catch (const InputError&) {
    r.fail(broker, prefix + ".broker", "'" + address + "' is not HOST:PORT", "e.g. broker: 127.0.0.1:1883");
  }
  if (auto n = YamlReader::optional(node, "topic")) {
    link.topic = r.text(n, prefix + ".topic", "the site's topic root, e.g. skylit/sample-gate");
    if (link.topic.empty() || link.topic.find_first_of("+#") != std::string::npos || link.topic.back() == '/') {
      r.fail(n, prefix + ".topic", "'" + link.topic + "' is not a topic root (no +, #, or trailing /)", "e.g. topic: skylit/sample-gate");
    }
  }
  if (auto n = YamlReader::optional(node, "node")) link.node = sky_link::node_name(r.text(n, prefix + ".node", "this node's name, e.g. hmd-1"));
  if (auto n = YamlReader::optional(node, "username")) link.mqtt.username = r.text(n, prefix + ".username", "the broker's user name");
  const auto password = YamlReader::optional(node, "password");
  const auto password_file = YamlReader::optional(node, "password_file");
  if (password && password_file) r.fail(password_file, prefix + ".password_file", "both password and password_file are given", "keep one");
  if (password) link.mqtt.password = r.text(password, prefix + ".password", "the broker password");
  if (password_file) {
    // A file of its own keeps the secret out of a config that is copied around (chmod 600 it).
    const std::filesystem::path path = r.any_path(password_file, prefix + ".password_file", "a file holding the password");
    if (!std::filesystem::is_regular_file(path)) {
      r.fail(password_file, prefix + ".password_file", "no file at " + path.string(), "write the password to that file (chmod 600)");
    }
    std::string text = read_file(path);
    while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
    link.mqtt.password = text;
  }
  if ((password || password_file) && link.mqtt.username.empty()) {
    r.fail(password ? password : password_file, prefix + ".username", "a password without a username", "add username: NAME");
  }
  if (auto tls = YamlReader::optional(node, "tls")) {
    r.expect_map(tls, prefix + ".tls", "tls: {ca_file: ca.crt, cert_file: node.crt, key_file: node.key}; " + std::string(kSiteDocs));
    r.check_keys(tls, prefix + ".tls.", kTlsKeys);
    const auto file_of = [&](const char* key, bool required) -> std::string {
      const auto n = required ? r.require(tls, key, prefix + ".tls." + key, "a PEM file") : YamlReader::optional(tls, key);
      if (!n) return {};
      const std::filesystem::path path = r.any_path(n, prefix + ".tls." + key, "a PEM file");
      if (!std::filesystem::is_regular_file(path)) r.fail(n, prefix + ".tls." + key, "no file at " + path.string(), "give a PEM file");
      return path.string();
    };
    link.mqtt.tls.ca_file = file_of("ca_file", true);
    link.mqtt.tls.cert_file = file_of("cert_file", false);
    link.mqtt.tls.key_file = file_of("key_file", false);
    if (link.mqtt.tls.cert_file.empty() != link.mqtt.tls.key_file.empty()) {
      r.fail(tls, prefix + ".tls", "cert_file and key_file go together", "give both, or neither");
    }
  }
  if (auto n = YamlReader::optional(node, "keepalive_s")) {
    link.mqtt.keepalive_s = static_cast<int>(r.integer(n, prefix + ".keepalive_s", 5, 3600, "seconds, 5 or more (a node is declared gone after 1.5 × this)"));
  }
  return link;
}

void parse_max_sources(const YamlReader& r, const YAML::Node& sky, SkySettings& settings) {
  if (auto n = YamlReader::optional(sky, "max_sources")) {
    settings.max_sources = static_cast<int>(r.integer(n, "sky.max_sources", 1, blend::kMaxGpuSources,
                                                      "1 (the sun alone) outdoors; 16 under many lamps (docs/live.md)"));
  }
}

// sky.bracket: 2 to 8 distinct positive exposure times, in seconds.
void parse_bracket(const YamlReader& r, const YAML::Node& n, SkySettings& settings) {
  constexpr const char* kHint = "2 to 8 exposure times in seconds, e.g. [0.0005, 0.004, 0.032]";
  if (!n.IsSequence() || n.size() < 2 || n.size() > 8) r.fail(n, "sky.bracket", "needs 2 to 8 exposure times", kHint);
  const std::vector<double> times = r.numbers(n, n.size(), "sky.bracket", kHint);
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!(times[k] > 0.0 && times[k] < 10.0)) r.fail(n, "sky.bracket", "exposure times must be in (0, 10) s", kHint);
    for (std::size_t j = 0; j < k; ++j) {
      if (times[j] == times[k]) r.fail(n, "sky.bracket", "an exposure time repeats", "give each time once");
    }
  }
  settings.bracket = times;
}

void parse_sky(const YamlReader& r, const YAML::Node& root, const std::filesystem::path& file, LiveConfig& c) {
  const YAML::Node sky = r.require(root, "sky", "sky", "the sky camera: calibration and source");
  r.expect_map(sky, "sky", kDocs);
  r.check_keys(sky, "sky.", kSkyKeys);
  const YAML::Node source = r.require(sky, "source", "sky.source", "where sky frames come from");
  if (source.IsMap() && source["kind"] && source["kind"].IsScalar() && source["kind"].Scalar() == "mqtt") {
    // An HMD node: the sky node estimates; its calibration and settings are its own.
    c.sky.link = parse_link(r, source, "sky.source");
    if (auto n = YamlReader::optional(sky, "stale_after")) c.sky.stale_after = r.positive(n, "sky.stale_after", "seconds, e.g. 30");
    parse_max_sources(r, sky, c.sky);
    return;
  }
  c.sky.calibration = r.path(r.require(sky, "calibration", "sky.calibration", "the sky camera's calibration YAML"),
                             "sky.calibration", kDocs);
  c.sky.source = capture::parse_source_config(source, file, r.root());
  if (auto n = YamlReader::optional(sky, "response")) {
    const std::string value = r.text(n, "sky.response", "srgb, linear or a response file");
    c.sky.response = value == "srgb" || value == "linear" ? value : r.path(n, "sky.response", kDocs).string();
  }
  if (auto n = YamlReader::optional(sky, "rate")) c.sky.rate = r.non_negative(n, "sky.rate", "estimates per second, 0 for every frame");
  if (auto n = YamlReader::optional(sky, "sun")) {
    constexpr std::array<std::string_view, 2> modes{"auto", "off"};
    c.sky.sun = r.choice(n, "sky.sun", modes) == "auto";
  }
  if (auto n = YamlReader::optional(sky, "smoothing")) c.sky.smoothing = r.non_negative(n, "sky.smoothing", "seconds, 0 for none");
  if (auto n = YamlReader::optional(sky, "stale_after")) c.sky.stale_after = r.positive(n, "sky.stale_after", "seconds, e.g. 30");
  if (auto n = YamlReader::optional(sky, "sun_colour")) {
    constexpr std::array<std::string_view, 2> modes{"daylight", "measured"};
    c.sky.correct_sun_colour = r.choice(n, "sky.sun_colour", modes) == "daylight";
  }
  if (auto n = YamlReader::optional(sky, "clipped_sun_energy")) {
    constexpr std::array<std::string_view, 3> modes{"measured", "clear_sky", "shadow_contrast"};
    c.sky.clipped_sun_energy =
        sky::parse_clipped_sun_energy(std::string(r.choice(n, "sky.clipped_sun_energy", modes)), "sky.clipped_sun_energy");
  }
  if (auto n = YamlReader::optional(sky, "bracket")) parse_bracket(r, n, c.sky);
  parse_max_sources(r, sky, c.sky);
}

void parse_camera(const YamlReader& r, const YAML::Node& root, const std::filesystem::path& file, LiveConfig& c) {
  const YAML::Node camera = r.require(root, "camera", "camera", "the HMD camera: calibration and source");
  r.expect_map(camera, "camera", kDocs);
  r.check_keys(camera, "camera.", kCameraKeys);
  const auto stereo = YamlReader::optional(camera, "stereo");
  if (stereo && YamlReader::optional(camera, "calibration")) {
    r.fail(stereo, "camera.stereo", "both calibration and stereo are given",
           "keep stereo (a camera per eye, from skylit-calib stereo) or calibration (one camera)");
  }
  if (stereo) {
    c.camera.stereo = r.path(stereo, "camera.stereo", kDocs);
  } else {
    c.camera.calibration = r.path(r.require(camera, "calibration", "camera.calibration",
                                            "the HMD camera's calibration YAML (or stereo: a stereo camera's)"),
                                  "camera.calibration", kDocs);
  }
  c.camera.source = capture::parse_source_config(r.require(camera, "source", "camera.source", "where camera frames come from"), file, r.root());
}

// pose, and the imu and fusion that correct the marker tracker's poses.
void parse_pose(const YamlReader& r, const YAML::Node& root, const std::filesystem::path& file, LiveConfig& c) {
  const YAML::Node pose = r.require(root, "pose", "pose", "a fixed pose, a pose track or the marker tracker");
  c.pose = track::parse_pose_config(pose, file, r.root());
  if (c.pose.kind == track::PoseConfig::Kind::Markers) {
    // Checked here rather than when the service opens it, so that the message points at the field.
    if (!std::filesystem::is_regular_file(c.pose.marker_map)) {
      r.fail(pose["map"], "pose.map", "no marker map at " + c.pose.marker_map.string(),
             "write the path of the site's marker map (relative to this file's folder); docs/tracking.md");
    }
    if (!c.pose.marker_calibration.empty() && !std::filesystem::is_regular_file(c.pose.marker_calibration)) {
      r.fail(pose["calibration"], "pose.calibration", "no calibration at " + c.pose.marker_calibration.string(),
             "write the HMD camera's calibration file, or leave the field out to use camera.calibration");
    }
  }
  // The IMU and the fusion correct the marker tracker's poses: a fixed pose or a pose track has
  // nothing for them to correct.
  for (const char* key : {"imu", "fusion"}) {
    if (auto n = YamlReader::optional(root, key); n && c.pose.kind != track::PoseConfig::Kind::Markers) {
      r.fail(n, key, "it fuses the marker tracker's poses, and pose.kind is not markers",
             "set 'pose: {kind: markers, map: ...}', or remove '" + std::string(key) + "'; docs/live.md (Pose)");
    }
  }
  if (auto n = YamlReader::optional(root, "imu")) {
    c.imu = track::parse_imu_config(n, file, r.root());
    if (c.imu->kind == track::ImuConfig::Kind::Replay && !std::filesystem::is_regular_file(c.imu->csv)) {
      r.fail(n["csv"], "imu.csv", "no IMU recording at " + c.imu->csv.string(),
             "write the path of a CSV with the header timestamp,gx,gy,gz,ax,ay,az; docs/imu.md");
    }
  }
  if (auto n = YamlReader::optional(root, "fusion")) c.fusion = track::parse_fusion_settings(n, file);
}

void parse_tracking(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto tracking = YamlReader::optional(root, "tracking")) {
    r.expect_map(tracking, "tracking", "tracking: {fade_s: 0.3}; " + std::string(kDocs));
    r.check_keys(tracking, "tracking.", kTrackingKeys);
    if (auto n = YamlReader::optional(tracking, "fade_s")) {
      c.tracking.fade_s = r.non_negative(n, "tracking.fade_s", "seconds the building takes to fade out or in, e.g. 0.3 (0: at once)");
    }
  }
}

void parse_blend(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto blend = YamlReader::optional(root, "blend"); blend && blend.IsScalar()) {
    c.blend.device = parse_blend_device(r, blend, "blend");  // the short form: `blend: cpu`
  } else if (blend) {
    r.expect_map(blend, "blend", kDocs);
    r.check_keys(blend, "blend.", kBlendKeys);
    if (auto n = YamlReader::optional(blend, "device")) c.blend.device = parse_blend_device(r, n, "blend.device");
    if (auto n = YamlReader::optional(blend, "threads")) {
      c.blend.threads = static_cast<int>(r.integer(n, "blend.threads", 0, 256, "CPU blend threads, 0 for all hardware threads"));
    }
    if (auto n = YamlReader::optional(blend, "storage")) {
      c.blend.storage = *blend::parse_storage(r.choice(n, "blend.storage", blend::kStorageNames));
    }
    if (auto n = YamlReader::optional(blend, "basis")) c.blend.basis = *blend::parse_form(r.choice(n, "blend.basis", blend::kFormNames));
    if (c.blend.basis == blend::BasisForm::Pca && c.blend.storage != blend::BasisStorage::Half) {
      // A PCA form's eigen-images take either sign; 8-bit and EAC layers store [0, 1] only.
      r.fail(blend["storage"] ? blend["storage"] : blend["basis"], "blend.storage",
             std::string(blend::storage_name(c.blend.storage)) +
                 " cannot hold the PCA form's eigen-images, whose values may be negative (blend.basis is pca)",
             "set 'storage: half', or 'basis: full'");
    }
    if (auto n = YamlReader::optional(blend, "skip_threshold")) c.blend.skip_threshold = r.non_negative(n, "blend.skip_threshold", "T units, e.g. 0.002");
    if (auto n = YamlReader::optional(blend, "change_threshold")) c.blend.change_threshold = r.non_negative(n, "blend.change_threshold", "T units, e.g. 0.002");
    if (auto n = YamlReader::optional(blend, "cull_planes")) c.blend.cull_planes = r.boolean(n, "blend.cull_planes", "true or false");
  }
}

void parse_render(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto render = YamlReader::optional(root, "render")) {
    r.expect_map(render, "render", "render: {scale: 0.75}; " + std::string(kDocs));
    r.check_keys(render, "render.", kRenderKeys);
    if (auto n = YamlReader::optional(render, "scale")) {
      c.render.scale = r.positive(n, "render.scale", "the building's render scale in (0, 1], e.g. 0.75");
      if (c.render.scale > 1.0) r.fail(n, "render.scale", "is over 1", "a scale in (0, 1], e.g. 0.75 (1: the frame's resolution)");
    }
    if (auto n = YamlReader::optional(render, "ground_light")) {
      c.render.ground_light = r.boolean(n, "render.ground_light", "true (the bake's ground layer lights the building) or false");
    }
    if (auto n = YamlReader::optional(render, "light_map")) {
      c.render.light_map = r.boolean(n, "render.light_map", "true (the bake's light map, where it has one) or false (the vertices alone)");
    }
    if (auto n = YamlReader::optional(render, "light_map_form")) {
      constexpr std::array<std::string_view, 3> forms{"auto", "full", "pca"};
      c.render.light_map_form = r.choice(n, "render.light_map_form", forms);
    }
    if (auto n = YamlReader::optional(render, "light_map_precision")) {
      c.render.light_map_precision = light_map_precision(r, n, "render.light_map_precision");
    }
    if (auto n = YamlReader::optional(render, "ground_albedo")) {
      const std::string fix = "the ground's reflectance in [0, 1]: a number, e.g. 0.2, or [r, g, b]";
      const std::vector<double> v = n.IsSequence() ? r.numbers(n, 3, "render.ground_albedo", fix)
                                                   : std::vector<double>(3, r.number(n, "render.ground_albedo", fix));
      for (double a : v) {
        if (!(a >= 0.0 && a <= 1.0)) r.fail(n, "render.ground_albedo", "must lie in [0, 1]", fix);
      }
      c.render.ground_albedo = Eigen::Vector3d(v[0], v[1], v[2]);
    }
  }
}

void parse_photometric(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto photometric = YamlReader::optional(root, "photometric")) {
    r.expect_map(photometric, "photometric", kDocs);
    r.check_keys(photometric, "photometric.", kPhotometricKeys);
    const auto scale = YamlReader::optional(photometric, "scale");
    const auto estimate = YamlReader::optional(photometric, "estimate");
    if (scale && estimate) r.fail(estimate, "photometric.estimate", "both scale and estimate are given", "keep one of them");
    if (scale) {
      const auto k = r.numbers(scale, 3, "photometric.scale", "[r, g, b], positive");
      for (int ch = 0; ch < 3; ++ch) {
        if (k[static_cast<std::size_t>(ch)] <= 0) r.fail(scale, "photometric.scale", "must be positive", "[r, g, b], e.g. [1, 1, 1]");
        c.photometric.scale[ch] = k[static_cast<std::size_t>(ch)];
      }
    }
    if (estimate) {
      r.expect_map(estimate, "photometric.estimate", kDocs);
      r.check_keys(estimate, "photometric.estimate.", kEstimateKeys);
      c.photometric.plane = r.text(r.require(estimate, "plane", "photometric.estimate.plane", "a real plane of the site, e.g. ground"),
                                   "photometric.estimate.plane", "a plane name");
      if (auto n = YamlReader::optional(estimate, "region")) c.photometric.region = parse_region(r, n, "photometric.estimate.region");
      if (auto n = YamlReader::optional(estimate, "shadowed_region")) {
        c.photometric.shadowed_region = parse_region(r, n, "photometric.estimate.shadowed_region");
      }
      if (auto n = YamlReader::optional(estimate, "shadowed_sky_visibility")) {
        const double v = r.positive(n, "photometric.estimate.shadowed_sky_visibility",
                                    "in (0, 1]: the shadowed region over the lit one under an overcast sky");
        if (v > 1.0) {
          r.fail(n, "photometric.estimate.shadowed_sky_visibility", "is above 1",
                 "the shadowed region's brightness over the lit region's under an overcast sky, at most 1");
        }
        c.photometric.shadowed_sky_visibility = v;
      }
      if (auto n = YamlReader::optional(estimate, "albedo")) {
        const auto v = r.numbers(n, 3, "photometric.estimate.albedo", "[r, g, b] in (0, 1]");
        for (int ch = 0; ch < 3; ++ch) {
          const double a = v[static_cast<std::size_t>(ch)];
          if (!(a > 0 && a <= 1)) r.fail(n, "photometric.estimate.albedo", "must be in (0, 1]", "e.g. [0.2, 0.2, 0.2]");
          c.photometric.albedo[ch] = a;
        }
      }
      if (auto n = YamlReader::optional(estimate, "every")) {
        c.photometric.every = static_cast<int>(r.integer(n, "photometric.estimate.every", 1, 1000000, "frames between estimates"));
      }
    }
  }
}

void parse_output(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto output = YamlReader::optional(root, "output")) {
    r.expect_map(output, "output", kDocs);
    r.check_keys(output, "output.", kOutputKeys);
    if (auto n = YamlReader::optional(output, "record"); n && n.IsMap()) {
      r.check_keys(n, "output.record.", kRecordKeys);
      if (auto p = YamlReader::optional(n, "path")) c.output.record = r.any_path(p, "output.record.path", "a video file or a folder");
      if (auto f = YamlReader::optional(n, "fps")) c.output.record_fps = r.positive(f, "output.record.fps", "frames per second, e.g. 30");
    } else if (n) {
      c.output.record = r.any_path(n, "output.record", "a video file or a folder, or {path: ..., fps: ...}");
    }
    if (auto n = YamlReader::optional(output, "window")) c.output.window = r.boolean(n, "output.window", "true or false");
  }
}

void parse_status(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto status = YamlReader::optional(root, "status")) {
    r.expect_map(status, "status", kDocs);
    r.check_keys(status, "status.", kStatusKeys);
    // Without `listen` the map still sets the access, for an address given with --status.
    if (auto n = YamlReader::optional(status, "listen")) c.status_listen = r.text(n, "status.listen", "ADDR:PORT, e.g. 127.0.0.1:8080");
    if (auto n = YamlReader::optional(status, "token_file")) {
      c.status_access.token_file = r.any_path(n, "status.token_file", "a file holding the console's token");
      if (!std::filesystem::is_regular_file(c.status_access.token_file)) {
        r.fail(n, "status.token_file", "no file at " + c.status_access.token_file.string(),
               "write a secret to it, e.g. head -c 24 /dev/urandom | base64 > FILE; chmod 600 FILE");
      }
    }
    if (auto n = YamlReader::optional(status, "allow_unauthenticated")) {
      c.status_access.allow_unauthenticated = r.boolean(n, "status.allow_unauthenticated", "true or false");
    }
  }
}

void parse_display(const YamlReader& r, const YAML::Node& root, LiveConfig& c) {
  if (auto display = YamlReader::optional(root, "display")) {
    r.expect_map(display, "display", "display: {profile: hmd/generic.yaml, monitor: NAME, mode: mono | stereo}; see docs/hmd.md");
    r.check_keys(display, "display.", kDisplayKeys);
    DisplaySettings d;
    d.profile = r.path(r.require(display, "profile", "display.profile", "an HMD profile, e.g. profile: hmd/generic.yaml"),
                       "display.profile", "an HMD profile (config/hmd/)");
    if (auto n = YamlReader::optional(display, "monitor")) d.monitor = r.text(n, "display.monitor", "the monitor's name, e.g. HDMI-1");
    if (auto n = YamlReader::optional(display, "mode")) d.stereo = r.choice(n, "display.mode", kDisplayModes) == "stereo";
    c.display = d;
  }
}

}  // namespace

std::string site_name_of(const std::filesystem::path& site_file) { return site_file.stem().string(); }

SkyNodeConfig load_sky_node_config(const std::filesystem::path& file) {
  constexpr std::array<std::string_view, 7> keys{"site", "bake", "preset", "sky", "link", "status", "root"};
  YamlReader reader(file);
  const YAML::Node root = reader.load();
  reader.expect_map(root, "", "a skylit-sky-node config is a map with site, bake, sky and link; " + std::string(kSiteDocs));
  reader.check_keys(root, "", keys);
  reader.read_root(root);
  const YamlReader& r = reader;
  LiveConfig c;  // the sky stage's part of a skylit-live config, read by the same code
  c.file = file;
  c.site = r.path(r.require(root, "site", "site", "the site file, e.g. site: sample_site.yaml"), "site", kSiteDocs);
  c.bake = r.path(r.require(root, "bake", "bake", "the bake folder whose dome the skies are for"), "bake", kSiteDocs);
  apply_preset(r, root, file, c);
  parse_sky(r, root, file, c);
  if (c.sky.clipped_sun_energy == sky::ClippedSunEnergy::ShadowContrast) {
    r.fail(root["sky"]["clipped_sun_energy"], "sky.clipped_sun_energy",
           "shadow_contrast is measured by the HMD nodes, whose cameras see the ground",
           "use measured or clear_sky here, and set shadow_contrast in the HMD nodes' skylit-live configs");
  }
  if (c.sky.link) {
    r.fail(root["sky"]["source"], "sky.source", "a sky node estimates the sky and cannot take it from MQTT",
           "give the sky camera's source (e.g. {kind: sky-sim, ...}); the broker goes under link:");
  }
  parse_status(r, root, c);
  SkyNodeConfig n;
  n.file = file;
  n.site = c.site;
  n.bake = c.bake;
  n.preset = c.preset;
  n.sky = c.sky;
  n.status_listen = c.status_listen;
  n.status_access = c.status_access;
  n.link = parse_link(r, r.require(root, "link", "link", "the broker to publish to, e.g. link: {broker: 127.0.0.1:1883}"), "link");
  if (auto kind = YamlReader::optional(root["link"], "kind")) r.fail(kind, "link.kind", "is not a field of link", "remove it");
  return n;
}

LiveConfig load_live_config(const std::filesystem::path& file) {
  YamlReader reader(file);
  const YAML::Node root = reader.load();
  reader.expect_map(root, "", "a skylit-live config is a map with site, bake, sky, camera and pose; " + std::string(kDocs));
  reader.check_keys(root, "", kTopKeys);
  reader.read_root(root);
  const YamlReader& r = reader;

  LiveConfig c;
  c.file = file;
  c.site = r.path(r.require(root, "site", "site", "the site file, e.g. site: sample_site.yaml"), "site", kDocs);
  c.bake = r.path(r.require(root, "bake", "bake", "the bake folder, e.g. bake: ../build/demo/bake"), "bake", kDocs);
  apply_preset(r, root, file, c);
  parse_sky(r, root, file, c);
  parse_camera(r, root, file, c);
  parse_pose(r, root, file, c);
  parse_tracking(r, root, c);
  parse_blend(r, root, c);
  parse_render(r, root, c);
  parse_photometric(r, root, c);
  if (c.sky.clipped_sun_energy == sky::ClippedSunEnergy::ShadowContrast && !c.photometric.shadowed_region) {
    r.fail(root["sky"]["clipped_sun_energy"], "sky.clipped_sun_energy",
           "shadow_contrast needs a real shadow on the photometric region's plane",
           "give photometric.estimate.shadowed_region: [s0, s1, t0, t1], ground in a real shadow beside the region");
  }
  parse_output(r, root, c);
  parse_status(r, root, c);
  parse_display(r, root, c);
  return c;
}

}  // namespace skylit::live
