#pragma once
// The frame log beside a skylit-live recording: CSV, a line per recorded frame (frame, file,
// timestamp, sky_timestamp, sky_utc, sun_elevation_deg, sun_azimuth_deg, opacity). The service
// writes it as it records; skylit-contact-sheet reads it back for its labels.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace skylit::live {

// "video" for a recording to a video file (.mp4, .avi, .mkv), "images" for a folder of PNGs.
std::string recorder_kind(const std::filesystem::path& path);

// Where a recording's frame log is: `live.mp4` → `live.csv`, a folder of PNGs → its
// `frames.csv` (which the images source reads back).
std::filesystem::path frame_log_path(const std::filesystem::path& record);

// What the frame log says of each recorded frame (the contact sheet's labels come from it).
struct RecordedFrame {
  double timestamp = 0;                          // the camera frame's
  std::optional<double> sky_timestamp;           // the sky frame's, on the sky source's clock; none: no sky yet
  std::optional<std::chrono::sys_seconds> sky_utc;
  std::optional<Eigen::Vector3d> sun_direction;  // towards the sun, when the sky has one
  std::optional<double> opacity;                 // the building's (BuildingFade); none: the camera image as it came
};

// Writes the log of the recording at `record` a line at a time, each flushed as it goes; the
// file is created with the first line. InputError when it cannot be written.
class FrameLogWriter {
 public:
  explicit FrameLogWriter(std::filesystem::path record) : record_(std::move(record)) {}
  // Frame number `frame` of the recording, stored as `file` (the video's name, or its PNG's).
  void add(std::int64_t frame, const std::string& file, const RecordedFrame& info);

 private:
  std::filesystem::path record_;
  std::ofstream log_;
};

// One line of a frame log as read back. An empty field reads as none.
struct LoggedFrame {
  std::int64_t frame = 0;
  std::string file;
  std::optional<double> timestamp;
  std::optional<double> sky_timestamp;  // none: composited before the first sky
  std::optional<std::chrono::sys_seconds> sky_utc;
  std::optional<double> sun_elevation_deg, sun_azimuth_deg;  // none: no sun
  std::optional<double> opacity;
};

// Reads a frame log (frame_log_path of a recording). Its header must name frame, file,
// sky_timestamp, sky_utc and sun_elevation_deg; timestamp, sun_azimuth_deg and opacity are read
// when present. InputError naming the file, line and field when it is missing, empty or malformed.
std::vector<LoggedFrame> read_frame_log(const std::filesystem::path& log);

}  // namespace skylit::live
