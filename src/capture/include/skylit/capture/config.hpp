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
#include "skylit/capture/reconnecting_source.hpp"
#include "skylit/capture/sources.hpp"

namespace YAML {
class Node;
}

namespace skylit::capture {

// A `source:` node of a config file:
//
//   source:
//     kind: images            # images | video | v4l2 | libcamera | sky-sim
//     name: sky               # optional: how the source is named in messages and status
//     path: recordings/sky/   # images: a folder or a glob; video: file
//     ...                     # the kind's own fields (docs/live.md, "Frame sources")
//
// Relative paths are taken from the config file's folder.
struct SourceConfig {
  std::string name;  // empty: the source's describe()
  std::variant<ImagesSettings, VideoSettings, V4l2Settings, LibcameraSettings, SkySimSettings> settings{};
  FrameChecks checks;
  // Reopen after failures (default on for cameras, off for files and the simulator).
  std::optional<BackoffSettings> reconnect{};
  // Hand out the frames of files and of the simulator at their recorded pace, × speed.
  std::optional<double> realtime_speed{};
};

// "images", "video", "v4l2", "libcamera", "sky-sim".
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
std::unique_ptr<FrameSource> open_source(const SourceConfig& config, Clock clock = steady_clock());

// open_source's source, with the ReconnectingSource inside it kept in view so that a service can
// report its connection state (ReconnectingSource::status()). `reconnecting` is null when the
// config turns reconnection off; it lives as long as `source`.
struct OpenedSource {
  std::unique_ptr<FrameSource> source;
  const ReconnectingSource* reconnecting = nullptr;
};
OpenedSource open_source_with_status(const SourceConfig& config, Clock clock = steady_clock());

}  // namespace skylit::capture
