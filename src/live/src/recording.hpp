#pragma once
// The service's recording: composited frames to a video file or a folder of PNGs, with the frame
// log beside them (skylit/live/frame_log.hpp).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/videoio.hpp>

#include "service_metrics.hpp"
#include "skylit/live/frame_log.hpp"

namespace skylit::live {

// Composited frames to a video file or a folder of PNGs, with a frame log beside them (CSV, one
// line per frame, flushed as it goes: `live.mp4` → `live.csv`, a folder → its `frames.csv`, which
// the images source reads back).
//
// A video's frame rate: `fps` when given (record.fps), else the HMD camera's (FrameRate, from its
// frames' timestamps, or `fallback_fps` from its config when too few frames came to measure it).
// The rate must be known when the file is opened, so the first frames wait here (a few seconds at
// most) until the camera's rate is settled.
class Recorder {
 public:
  Recorder(std::filesystem::path path, std::optional<double> fps, std::optional<double> fallback_fps)
      : path_(std::move(path)), fps_(fps), fallback_fps_(fallback_fps), log_(path_) {}
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  void write(const cv::Mat& frame, const RecordedFrame& info, const FrameRate& camera_rate);

  // Writes the frames that wait for the rate (at the end of a run).
  void finish(const FrameRate& camera_rate);

  // The video's frame rate (0 before the file is opened, and for a folder of images).
  double fps() const { return opened_fps_; }

  // Frames that could not be written (a full disk, a folder or video removed): the service goes
  // on, says so in its status, and writes again once it can. The frame log has a line per
  // written frame.
  struct Health {
    std::int64_t written = 0;
    std::int64_t lost = 0;
    bool failing = false;     // the last write failed
    std::string last_error;   // of the last failure
  };
  Health health() const { return health_; }

 private:
  static constexpr std::size_t kMaxPendingFrames = 2 * kRateIntervals;

  void open(cv::Size size, const FrameRate& camera_rate);
  void flush_pending();
  void write_video(const cv::Mat& frame, const RecordedFrame& info);
  // Why a frame of `frame_bytes` cannot go to the video now (no room, the file removed); "" if it can.
  std::string video_write_problem(std::uintmax_t frame_bytes) const;
  void write_image(const cv::Mat& frame, const RecordedFrame& info);

  std::filesystem::path path_;
  std::optional<double> fps_, fallback_fps_;
  double opened_fps_ = 0;
  std::vector<std::pair<cv::Mat, RecordedFrame>> pending_;
  cv::VideoWriter writer_;
  FrameLogWriter log_;
  std::int64_t count_ = 0;
  Health health_;
};

}  // namespace skylit::live
