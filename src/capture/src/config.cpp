// The `source:` node of a config file, and the factory that opens what it describes.
#include "skylit/capture/config.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/base/yaml_reader.hpp"
#include "skylit/sky/solar.hpp"

namespace skylit::capture {
namespace {

namespace fs = std::filesystem;

const char* const kDocs = "see docs/live.md (Frame sources)";

constexpr std::array<std::string_view, 6> kCommonKeys{"kind", "name", "width", "height", "reconnect", "realtime"};
constexpr std::array<std::string_view, 4> kImagesKeys{"path", "timestamps", "fps", "loop"};
constexpr std::array<std::string_view, 2> kVideoKeys{"path", "loop"};
constexpr std::array<std::string_view, 4> kV4l2Keys{"device", "fps", "fourcc", "bracket_settle_frames"};
constexpr std::array<std::string_view, 6> kLibcameraKeys{"camera",        "pixel_format", "buffer_count",
                                                         "exposure_time", "gain",         "bracket_settle_frames"};
constexpr std::array<std::string_view, 14> kSkySimKeys{"calibration", "sky",       "equirect",  "azimuth_offset",
                                                       "start",       "every",     "frames",    "latitude",
                                                       "longitude",   "turbidity", "zenith_radiance",
                                                       "supersample", "exposure_time", "gain"};
constexpr std::array<std::string_view, 4> kReconnectKeys{"initial", "max", "silence", "stale_after"};
constexpr std::array<std::string_view, 6> kPairKeys{"kind", "name", "realtime", "left", "right", "tolerance_ms"};
constexpr double kMaxPairToleranceMs = 100;
// In the order of SourceConfig::settings' alternatives; `pair` last (a pair's sides are the others).
constexpr std::array<std::string_view, 6> kKinds{"images", "video", "v4l2", "libcamera", "sky-sim", "pair"};

std::string join(std::span<const std::string_view> items) {
  std::string text;
  for (auto item : items) text += (text.empty() ? "" : ", ") + std::string(item);
  return text;
}

// Field readers that name the file, the line and column, and the field in every error.
using Reader = YamlReader;

std::vector<std::string_view> allowed_keys(std::span<const std::string_view> own) {
  std::vector<std::string_view> keys(kCommonKeys.begin(), kCommonKeys.end());
  keys.insert(keys.end(), own.begin(), own.end());
  return keys;
}

ImagesSettings parse_images(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  ImagesSettings s;
  s.path = r.path(r.require(node, "path", prefix + "path", "a folder of images or a glob, e.g. 'path: sky/*.png'"),
                  prefix + "path", "write a folder or a glob, e.g. 'path: sky/*.png'");
  if (const auto n = Reader::optional(node, "timestamps")) {
    s.timestamps = r.path(n, prefix + "timestamps", "write the CSV's path, e.g. 'timestamps: sky/frames.csv'");
  }
  if (const auto n = Reader::optional(node, "fps")) s.fps = r.positive(n, prefix + "fps", "give frames per second, e.g. 30");
  if (const auto n = Reader::optional(node, "loop")) s.loop = r.boolean(n, prefix + "loop", "write 'loop: true' or 'loop: false'");
  return s;
}

VideoSettings parse_video(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  VideoSettings s;
  s.file = r.path(r.require(node, "path", prefix + "path", "the video file, e.g. 'path: hmd.avi'"), prefix + "path",
                  "write the video file's path, e.g. 'path: hmd.avi'");
  if (const auto n = Reader::optional(node, "loop")) s.loop = r.boolean(n, prefix + "loop", "write 'loop: true' or 'loop: false'");
  return s;
}

V4l2Settings parse_v4l2(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  V4l2Settings s;
  if (const auto n = Reader::optional(node, "device")) {
    s.device = r.text(n, prefix + "device", "write an index (0) or a device node (/dev/video0)");
  }
  if (const auto n = Reader::optional(node, "fps")) s.fps = r.positive(n, prefix + "fps", "give frames per second, e.g. 30");
  if (const auto n = Reader::optional(node, "fourcc")) {
    s.fourcc = r.text(n, prefix + "fourcc", "write four characters, e.g. MJPG or YUYV");
    if (s.fourcc.size() != 4) r.fail(n, prefix + "fourcc", "'" + s.fourcc + "' is not four characters", "write e.g. MJPG or YUYV");
  }
  if (const auto n = Reader::optional(node, "bracket_settle_frames")) {
    s.bracket_settle_frames = static_cast<int>(r.integer(n, prefix + "bracket_settle_frames", 0, 64, "give 2 to 10 (4 is the default)"));
  }
  return s;
}

LibcameraSettings parse_libcamera(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  LibcameraSettings s;
  if (const auto n = Reader::optional(node, "camera")) {
    s.camera = r.text(n, prefix + "camera", "write an index (0), a camera id or a model name (cam --list shows them)");
  }
  if (const auto n = Reader::optional(node, "pixel_format")) {
    s.pixel_format = r.text(n, prefix + "pixel_format", "write one of RGB888, BGR888, XRGB8888, XBGR8888, YUYV, NV12, MJPEG");
    const auto& formats = libcamera_pixel_formats();
    if (std::find(formats.begin(), formats.end(), s.pixel_format) == formats.end()) {
      r.fail(n, prefix + "pixel_format", "'" + s.pixel_format + "' is not supported",
             "write one of RGB888, BGR888, XRGB8888, XBGR8888, YUYV, NV12, MJPEG");
    }
  }
  if (const auto n = Reader::optional(node, "buffer_count")) {
    s.buffer_count = static_cast<int>(r.integer(n, prefix + "buffer_count", 1, 32, "give 2 to 8 (4 is the default)"));
  }
  if (const auto n = Reader::optional(node, "exposure_time")) {
    s.exposure_time = r.positive(n, prefix + "exposure_time", "give seconds, e.g. 0.002, or leave it out for auto exposure");
  }
  if (const auto n = Reader::optional(node, "gain")) s.gain = r.positive(n, prefix + "gain", "give a linear analogue gain, e.g. 1");
  if (const auto n = Reader::optional(node, "bracket_settle_frames")) {
    s.bracket_settle_frames = static_cast<int>(r.integer(n, prefix + "bracket_settle_frames", 0, 64, "give 2 to 10 (8 is the default)"));
  }
  return s;
}

SkySimSettings parse_sky_sim(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  SkySimSettings s;
  s.calibration = r.path(r.require(node, "calibration", prefix + "calibration", "the sky camera's calibration, e.g. 'calibration: sky_camera.yaml'"),
                         prefix + "calibration", "write the calibration's path");
  const std::string sky_fix = "write 'sky: clear' (with start, latitude, longitude), 'sky: overcast' or 'sky: equirect' (with equirect)";
  const YAML::Node sky_node = r.require(node, "sky", prefix + "sky", sky_fix);
  const std::string sky = r.text(sky_node, prefix + "sky", sky_fix);
  if (sky == "clear") {
    s.sky = SkySimSettings::Sky::Clear;
  } else if (sky == "overcast") {
    s.sky = SkySimSettings::Sky::Overcast;
  } else if (sky == "equirect") {
    s.sky = SkySimSettings::Sky::Equirect;
  } else {
    r.fail(sky_node, prefix + "sky", "unknown sky '" + sky + "'", sky_fix);
  }
  if (s.sky == SkySimSettings::Sky::Equirect) {
    s.equirect = r.path(r.require(node, "equirect", prefix + "equirect", "the HDR sky image, e.g. 'equirect: sky.exr'"),
                        prefix + "equirect", "write the HDR sky image's path");
  } else if (const auto n = Reader::optional(node, "equirect")) {
    r.fail(n, prefix + "equirect", "only used with 'sky: equirect'", "remove it, or write 'sky: equirect'");
  }
  if (const auto n = Reader::optional(node, "azimuth_offset")) {
    s.azimuth_offset_deg = r.number(n, prefix + "azimuth_offset", "give degrees east of north, e.g. 90");
  }
  const std::string time_fix = "write an ISO 8601 time with a zone, e.g. 2026-06-21T09:30:00Z";
  const YAML::Node start = s.sky == SkySimSettings::Sky::Clear ? r.require(node, "start", prefix + "start", time_fix)
                                                               : Reader::optional(node, "start");
  if (start.IsDefined()) {
    try {
      s.start = sky::parse_utc(r.text(start, prefix + "start", time_fix));
    } catch (const InputError&) {
      r.fail(start, prefix + "start", "'" + start.Scalar() + "' is not an ISO 8601 time with a zone", time_fix);
    }
  }
  if (const auto n = Reader::optional(node, "every")) {
    try {
      s.step = sky::parse_interval(r.text(n, prefix + "every", "write e.g. 10min"));
    } catch (const InputError&) {
      r.fail(n, prefix + "every", "'" + n.Scalar() + "' is not an interval from 1 s to a year", "write a number and a unit: 30s, 10min, 1h");
    }
  }
  if (const auto n = Reader::optional(node, "frames")) {
    s.frames = r.integer(n, prefix + "frames", 0, 100000000, "give how many frames, or 0 for no end");
  }
  const bool clear = s.sky == SkySimSettings::Sky::Clear;
  const auto place = [&](const char* key, double lo, double hi, const std::string& fix) {
    const std::string field = prefix + key;
    const YAML::Node n = clear ? r.require(node, key, field, fix) : Reader::optional(node, key);
    if (!n.IsDefined()) return 0.0;
    const double value = r.number(n, field, fix);
    if (value < lo || value > hi) r.fail(n, field, n.Scalar() + " is outside [" + std::to_string(static_cast<int>(lo)) + ", " + std::to_string(static_cast<int>(hi)) + "]", fix);
    return value;
  };
  s.latitude_deg = place("latitude", -90, 90, "give degrees north (negative south), e.g. 34.68");
  s.longitude_deg = place("longitude", -180, 180, "give degrees east (negative west), e.g. 135.84");
  if (const auto n = Reader::optional(node, "turbidity")) {
    s.turbidity = r.number(n, prefix + "turbidity", "give 2 (very clear) to 10");
    if (s.turbidity < 2 || s.turbidity > 10) r.fail(n, prefix + "turbidity", n.Scalar() + " is outside [2, 10]", "give 2 (very clear) to 10");
  }
  if (const auto n = Reader::optional(node, "zenith_radiance")) {
    s.zenith_radiance = r.positive(n, prefix + "zenith_radiance", "give the overcast zenith radiance, e.g. 5");
  }
  if (const auto n = Reader::optional(node, "supersample")) {
    s.supersample = static_cast<int>(r.integer(n, prefix + "supersample", 1, 16, "use 1 (fast) to 4 (smooth)"));
  }
  if (const auto n = Reader::optional(node, "exposure_time")) {
    s.exposure_time = r.positive(n, prefix + "exposure_time", "give seconds (8-bit frames), or leave it out for float radiance");
  }
  if (const auto n = Reader::optional(node, "gain")) s.gain = r.positive(n, prefix + "gain", "give a linear gain, e.g. 1");
  return s;
}

std::optional<BackoffSettings> parse_reconnect(const Reader& r, const YAML::Node& node, const std::string& prefix, bool camera) {
  std::optional<BackoffSettings> settings;
  if (camera) settings = BackoffSettings{.initial_s = 0.5, .max_s = 30.0, .silence_s = 10.0, .stale_after_s = 2.0};
  const YAML::Node n = Reader::optional(node, "reconnect");
  if (!n.IsDefined()) return settings;
  const std::string fix = "write 'reconnect: false', or a map {initial: 0.5, max: 30, silence: 10, stale_after: 2} (seconds)";
  if (n.IsScalar()) {
    if (!r.boolean(n, prefix + "reconnect", fix)) return std::nullopt;
    return settings ? settings : BackoffSettings{};
  }
  if (!n.IsMap()) r.fail(n, prefix + "reconnect", "expected true, false or a map", fix);
  r.check_keys(n, prefix + "reconnect.", kReconnectKeys);
  BackoffSettings s = settings.value_or(BackoffSettings{});
  if (const auto v = Reader::optional(n, "initial")) s.initial_s = r.positive(v, prefix + "reconnect.initial", fix);
  if (const auto v = Reader::optional(n, "max")) {
    s.max_s = r.positive(v, prefix + "reconnect.max", fix);
    if (s.max_s < s.initial_s) r.fail(v, prefix + "reconnect.max", "shorter than reconnect.initial", "make max ≥ initial");
  }
  if (const auto v = Reader::optional(n, "silence")) {
    s.silence_s = r.number(v, prefix + "reconnect.silence", fix);
    if (s.silence_s < 0) r.fail(v, prefix + "reconnect.silence", "negative", "give seconds, or 0 for never");
  }
  if (const auto v = Reader::optional(n, "stale_after")) s.stale_after_s = r.positive(v, prefix + "reconnect.stale_after", fix);
  return s;
}

bool is_camera(const SourceConfig& config) {
  return std::holds_alternative<V4l2Settings>(config.settings) || std::holds_alternative<LibcameraSettings>(config.settings);
}

SourceConfig parse_source_node(const Reader& r, const YAML::Node& node, const std::string& field, bool pair_side);

// `kind: pair`: each side a full source node of its own, parsed as the top-level one is.
PairSettings parse_pair(const Reader& r, const YAML::Node& node, const std::string& prefix) {
  // A camera's mode and its reconnection belong to that camera: say where they go.
  for (const char* key : {"width", "height", "reconnect"}) {
    if (node[key].IsDefined()) {
      r.fail(Reader::key_node(node, key), prefix + key, "each camera of a pair has its own",
             std::string("move it under left: and right:; ") + kDocs);
    }
  }
  r.check_keys(node, prefix, kPairKeys);
  PairSettings s;
  const auto side = [&](const char* key, const char* device) {
    const std::string fix = std::string("give the ") + key + " camera's source node, e.g. '" + key +
                            ": {kind: v4l2, device: " + device + "}'";
    const YAML::Node side_node = r.require(node, key, prefix + key, fix);
    return std::make_shared<const SourceConfig>(parse_source_node(r, side_node, prefix + key, true));
  };
  s.left = side("left", "/dev/video0");
  s.right = side("right", "/dev/video2");
  if (const auto n = Reader::optional(node, "tolerance_ms")) {
    const std::string fix = "give milliseconds, below half a frame interval: e.g. 5 at 90 Hz, 15 at 30 Hz";
    const double ms = r.positive(n, prefix + "tolerance_ms", fix);
    if (ms > kMaxPairToleranceMs) r.fail(n, prefix + "tolerance_ms", n.Scalar() + " is above 100 ms", fix);
    s.tolerance_s = ms * 1e-3;
  }
  return s;
}

// A source node whose fields are named `field`.KEY in errors ("source", "source.left").
SourceConfig parse_source_node(const Reader& r, const YAML::Node& node, const std::string& field, bool pair_side) {
  const std::string prefix = field + ".";
  if (!node.IsDefined() || node.IsNull()) {
    r.fail(node, field, "missing", "add a '" + field + ":' map with a kind; " + kDocs);
  }
  if (!node.IsMap()) r.fail(node, field, "expected a map of fields", std::string("write 'kind: ...' and the kind's fields; ") + kDocs);
  // A pair's side is one source: the kinds but `pair`.
  const std::span<const std::string_view> kinds = pair_side ? std::span(kKinds).first(kKinds.size() - 1) : std::span(kKinds);
  const std::string kind_fix = "write 'kind:' and one of " + join(kinds);
  const YAML::Node kind_node = r.require(node, "kind", prefix + "kind", kind_fix);
  const std::string kind = r.text(kind_node, prefix + "kind", kind_fix);

  SourceConfig config;
  bool camera = false;
  if (kind == "images") {
    r.check_keys(node, prefix, allowed_keys(kImagesKeys));
    config.settings = parse_images(r, node, prefix);
  } else if (kind == "video") {
    r.check_keys(node, prefix, allowed_keys(kVideoKeys));
    config.settings = parse_video(r, node, prefix);
  } else if (kind == "v4l2") {
    r.check_keys(node, prefix, allowed_keys(kV4l2Keys));
    config.settings = parse_v4l2(r, node, prefix);
    camera = true;
  } else if (kind == "libcamera") {
    r.check_keys(node, prefix, allowed_keys(kLibcameraKeys));
    config.settings = parse_libcamera(r, node, prefix);
    camera = true;
  } else if (kind == "sky-sim") {
    r.check_keys(node, prefix, allowed_keys(kSkySimKeys));
    config.settings = parse_sky_sim(r, node, prefix);
  } else if (kind == "pair" && pair_side) {
    r.fail(kind_node, prefix + "kind", "a side of a pair is one camera or recording, not another pair", kind_fix);
  } else if (kind == "pair") {
    const PairSettings pair = parse_pair(r, node, prefix);
    camera = is_camera(*pair.left) || is_camera(*pair.right);
    config.settings = pair;
  } else {
    r.fail(kind_node, prefix + "kind", "unknown kind '" + kind + "'", unknown_key_fix(kind, kinds));
  }

  if (const auto n = Reader::optional(node, "name")) config.name = r.text(n, prefix + "name", "write a short name, e.g. sky");
  const auto size_field = [&](const char* key) -> int {
    const YAML::Node n = Reader::optional(node, key);
    if (!n.IsDefined()) return 0;
    return static_cast<int>(r.integer(n, prefix + key, 1, 1 << 15, "give pixels, e.g. 1024"));
  };
  const int width = size_field("width");
  const int height = size_field("height");
  if ((width > 0) != (height > 0)) {
    r.fail(node, prefix + (width > 0 ? "height" : "width"), "width and height go together", "give both, or neither");
  }
  if (width > 0) {
    config.checks.size = cv::Size(width, height);
    if (auto* v4l2 = std::get_if<V4l2Settings>(&config.settings)) {
      v4l2->width = width;
      v4l2->height = height;
    }
    if (auto* libcamera = std::get_if<LibcameraSettings>(&config.settings)) {
      libcamera->width = width;
      libcamera->height = height;
    }
  }
  // A pair's own reconnect was refused above; its sides have theirs.
  config.reconnect = parse_reconnect(r, node, prefix, camera && !std::holds_alternative<PairSettings>(config.settings));
  if (const auto n = Reader::optional(node, "realtime")) {
    const std::string fix = "write 'realtime: true' (recorded pace), a speed such as 'realtime: 10', or false";
    if (camera) r.fail(n, prefix + "realtime", "a camera is always real time", "remove it");
    if (n.IsScalar() && (n.Scalar() == "true" || n.Scalar() == "false")) {
      if (r.boolean(n, prefix + "realtime", fix)) config.realtime_speed = 1.0;
    } else {
      config.realtime_speed = r.positive(n, prefix + "realtime", fix);
    }
  }
  return config;
}

}  // namespace

std::string kind_name(const SourceConfig& config) {
  return std::string(kKinds[config.settings.index()]);
}

SourceConfig parse_source_config(const YAML::Node& node, const fs::path& file, const fs::path& root) {
  const Reader r(file, root);
  return parse_source_node(r, node, "source", false);
}

SourceConfig load_source_config(const fs::path& file) {
  YamlReader reader(file);
  const YAML::Node root = reader.parse(read_file(file));
  if (!root.IsMap()) {
    throw InputError(input_message(file, -1, -1, "source", "the file has no top-level map",
                                   std::string("write 'source:' with a kind and its fields; ") + kDocs));
  }
  reader.read_root(root);
  return parse_source_config(root["source"], file, reader.root());
}

std::unique_ptr<FrameSource> open_source(const SourceConfig& config, Clock clock) {
  return open_source_with_status(config, std::move(clock)).source;
}

namespace {

// The sides open as their own configs say; the pair is not reopened as a whole, since that
// would close the camera that still works and lose the frame waiting for its partner.
OpenedSource open_pair(const PairSettings& pair, const std::optional<BackoffSettings>& reconnect, const Clock& clock) {
  const auto open_side = [&](const SourceConfig& side) {
    SourceConfig config = side;
    if (!config.reconnect) config.reconnect = reconnect;
    return open_source_with_status(config, clock);
  };
  OpenedSource left = open_side(*pair.left);
  OpenedSource right = open_side(*pair.right);
  auto paired = std::make_unique<PairedSource>(std::move(left.source), std::move(right.source), pair.tolerance_s);
  OpenedSource opened;
  opened.paired = paired.get();
  opened.left_reconnecting = left.reconnecting;
  opened.right_reconnecting = right.reconnecting;
  opened.source = std::move(paired);
  return opened;
}

}  // namespace

OpenedSource open_source_with_status(const SourceConfig& config, Clock clock) {
  OpenedSource opened;
  std::unique_ptr<FrameSource>& source = opened.source;
  if (const auto* pair = std::get_if<PairSettings>(&config.settings)) {
    opened = open_pair(*pair, config.reconnect, clock);
  } else {
    const FrameChecks checks = config.checks;
    ReconnectingSource::Opener open = [settings = config.settings, checks]() -> std::unique_ptr<FrameSource> {
      return std::visit(
          [&checks](const auto& s) -> std::unique_ptr<FrameSource> {
            using T = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<T, ImagesSettings>) return std::make_unique<ImagesSource>(s, checks);
            if constexpr (std::is_same_v<T, VideoSettings>) return std::make_unique<VideoSource>(s, checks);
            if constexpr (std::is_same_v<T, V4l2Settings>) return std::make_unique<V4l2Source>(s, checks);
            if constexpr (std::is_same_v<T, LibcameraSettings>) return std::make_unique<LibcameraSource>(s, checks);
            if constexpr (std::is_same_v<T, SkySimSettings>) return std::make_unique<SkySimSource>(s, checks);
            if constexpr (std::is_same_v<T, PairSettings>) return nullptr;  // opened by open_pair
          },
          settings);
    };
    if (config.reconnect) {
      auto reconnecting = std::make_unique<ReconnectingSource>(std::move(open), *config.reconnect, clock);
      opened.reconnecting = reconnecting.get();
      source = std::move(reconnecting);
    } else {
      source = open();
    }
  }
  if (config.realtime_speed) source = std::make_unique<RealtimeSource>(std::move(source), *config.realtime_speed, clock);
  if (!config.name.empty()) source->set_name(config.name);
  return opened;
}

}  // namespace skylit::capture
