#pragma once
// A frame source described in a config file, and the factory that opens it (docs/live.md,
// "Frame sources").
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <variant>

#include "skylit/capture/frame_source.hpp"
#include "skylit/capture/libcamera_source.hpp"
#include "skylit/capture/paired_source.hpp"
#include "skylit/capture/reconnecting_source.hpp"
#include "skylit/capture/sources.hpp"

namespace YAML {
class Node;
}

namespace skylit::capture {

struct SourceConfig;

// A stereo camera as two sources paired by timestamp (PairedSource). The sides are immutable and
// shared, so that SourceConfig stays copyable.
struct PairSettings {
  std::shared_ptr<const SourceConfig> left;
  std::shared_ptr<const SourceConfig> right;
  double tolerance_s = 0.005;
};

// A `source:` node of a config file:
//
//   source:
//     kind: images            # images | video | v4l2 | libcamera | sky-sim | pair
//     name: sky               # optional: how the source is named in messages and status
//     path: recordings/sky/   # images: a folder or a glob; video: file
//     ...                     # the kind's own fields (docs/live.md, "Frame sources")
//
// `kind: pair` takes `left:` and `right:` (each a source node of one of the other kinds) and
// `tolerance_ms`. Relative paths are taken from the config file's folder.
struct SourceConfig {
  std::string name;  // empty: the source's describe()
  std::variant<ImagesSettings, VideoSettings, V4l2Settings, LibcameraSettings, SkySimSettings, PairSettings> settings{};
  FrameChecks checks;
  // Reopen after failures (default on for cameras, off for files and the simulator).
  std::optional<BackoffSettings> reconnect{};
  // Hand out the frames of files and of the simulator at their recorded pace, × speed.
  std::optional<double> realtime_speed{};
};

// "images", "video", "v4l2", "libcamera", "sky-sim", "pair".
std::string kind_name(const SourceConfig& config);

// Reads a `source:` node of `file` (the node's marks give the lines). InputError naming the
// file, line, column and field for anything missing, unknown or out of range.
// `root`: the folder its paths must lie in (the including config's root); empty, the file's folder.
SourceConfig parse_source_config(const YAML::Node& node, const std::filesystem::path& file,
                                 const std::filesystem::path& root = {});
// A YAML file whose top level has a `source:` node (other top-level keys are left alone; its
// `root:`, if any, is the folder the source's files must lie in).
SourceConfig load_source_config(const std::filesystem::path& file);

// Opens the source the config describes, wrapped in ReconnectingSource and RealtimeSource as
// configured. Errors of the first opening propagate (InputError for what a user can fix).
// A pair opens each side as its own config says (a camera side reconnecting on its own, so the
// other camera keeps running) and is not reopened as a whole; a `reconnect` set on the pair
// (skylit-live sets one on every source) goes to each side that has none.
std::unique_ptr<FrameSource> open_source(const SourceConfig& config, Clock clock = steady_clock());

// open_source's source, with the ReconnectingSource inside it kept in view so that a service can
// report its connection state (ReconnectingSource::status()). `reconnecting` is null when the
// config turns reconnection off, and for a pair, whose sides have their own (`left_reconnecting`,
// `right_reconnecting`) and whose PairedSource is `paired`. All live as long as `source`.
struct OpenedSource {
  std::unique_ptr<FrameSource> source;
  const ReconnectingSource* reconnecting = nullptr;
  const PairedSource* paired = nullptr;
  const ReconnectingSource* left_reconnecting = nullptr;
  const ReconnectingSource* right_reconnecting = nullptr;
};
OpenedSource open_source_with_status(const SourceConfig& config, Clock clock = steady_clock());

}  // namespace skylit::capture
