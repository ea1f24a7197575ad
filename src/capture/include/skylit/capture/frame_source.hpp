#pragma once
// Frame sources: one interface for every place frames come from (image sequences, video files,
// V4L2 and libcamera cameras, the sky simulator). Every backend's frames pass the same checks
// (empty, wrong size or type, all NaN: dropped and counted), so the live status shows one set of
// counters whatever the camera.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace skylit::capture {

// A frame as a source delivers it.
struct Frame {
  cv::Mat image;                  // BGR (or grey): CV_8U, CV_16U or CV_32F, 1 or 3 channels
  double timestamp = 0;           // seconds on the source's own steady clock (increasing)
  std::int64_t sequence = 0;      // the source's frame index (gaps where frames were lost)
  std::optional<double> exposure_time{};  // seconds, when the source knows it
  std::optional<double> gain{};           // linear analogue gain, when the source knows it
  // Wall-clock time of the frame when the source knows it (a live V4L2 or libcamera camera: the
  // system clock as the frame arrives; a simulated sky; a recording whose timestamps are ISO 8601
  // times); the sun's position needs it.
  std::optional<std::chrono::sys_seconds> utc{};
  std::string source;             // FrameSource::describe() of the source it came from
};

enum class FrameStatus {
  Ready,        // `frame` holds a frame
  EndOfStream,  // a finite source (file, sequence without loop) has no more frames
  NotYet,       // nothing within the timeout; ask again
};

struct FrameResult {
  FrameStatus status = FrameStatus::NotYet;
  Frame frame;
};

// A source has failed at run time (a camera unplugged, a device error). ReconnectingSource
// reopens the source after such a failure; errors a user can fix (a wrong path, an absent
// device at start) are InputError instead.
class CaptureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What a frame must look like. Empty fields take the first good frame's value, so a camera that
// changes size or type mid-stream has its odd frames dropped rather than passed to a sky table
// built for another size.
struct FrameChecks {
  std::optional<cv::Size> size{};  // expected width × height
  std::optional<int> type;       // expected OpenCV type (CV_8UC3, ...)
  bool lock_to_first = true;     // adopt the first good frame's size and type as expected
};

// Frames delivered and dropped, by reason (a snapshot; safe to take from any thread).
struct FrameCounts {
  std::int64_t delivered = 0;
  std::int64_t dropped_empty = 0;       // no pixels
  std::int64_t dropped_size = 0;        // not the expected width × height
  std::int64_t dropped_type = 0;        // depth or channels not accepted or not the expected ones
  std::int64_t dropped_all_nan = 0;     // a float frame with no finite pixel
  std::int64_t dropped_unreadable = 0;  // a file or buffer the backend could not decode
  std::int64_t dropped() const {
    return dropped_empty + dropped_size + dropped_type + dropped_all_nan + dropped_unreadable;
  }
  FrameCounts& operator+=(const FrameCounts& other);
};

// Why a frame is malformed under `checks` (None when it is fine); with lock_to_first a good frame
// fills the checks' empty fields. Accepted types: 8-bit, 16-bit or float, with 1 or 3 channels.
enum class FrameProblem { None, Empty, Size, Type, AllNaN };
FrameProblem check_frame(const cv::Mat& image, FrameChecks& checks);

class FrameSource {
 public:
  explicit FrameSource(FrameChecks checks = {}) : checks_(checks) {}
  virtual ~FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  // The next good frame, waiting at most `timeout_s` seconds (0: only what is ready now).
  // Malformed frames are dropped and counted here, for every backend. CaptureError when the
  // source has failed (see ReconnectingSource).
  FrameResult next(double timeout_s);

  // One frame per exposure time (seconds), in that order, at the current gain; malformed ones
  // are dropped and counted (so fewer may come back). nullopt when the source cannot bracket.
  std::optional<std::vector<Frame>> bracket(std::span<const double> exposure_times_s, double timeout_s);

  // "images /data/sky/*.png", "v4l2 /dev/video0 (UVC Camera)": for messages and Frame::source.
  virtual std::string describe() const = 0;

  // Manual exposure time (seconds) and analogue gain for the frames that follow; false when the
  // source has no such control (then nothing changed).
  virtual bool set_exposure_time(double seconds);
  virtual bool set_gain(double gain);

  // Counters since the source was made (a ReconnectingSource adds those of every reopening).
  virtual FrameCounts counts() const;

  // How frames are labelled (Frame::source): the name given (a config's `name:`), else describe().
  void set_name(std::string name) { name_ = std::move(name); }
  std::string name() const { return name_.empty() ? describe() : name_; }

 protected:
  // The backend's next frame, unchecked. Ready with an empty image counts as dropped_empty.
  virtual FrameResult read(double timeout_s) = 0;
  // The backend's bracket, unchecked; nullopt when unsupported (the default).
  virtual std::optional<std::vector<Frame>> read_bracket(std::span<const double> exposure_times_s,
                                                         double timeout_s);
  // For backends that skip a frame they cannot decode.
  void count_unreadable() { dropped_unreadable_.fetch_add(1, std::memory_order_relaxed); }

 private:
  bool accept(Frame& frame);  // checks, counts, names the source
  FrameChecks checks_;
  std::string name_;
  std::atomic<std::int64_t> delivered_{0};
  std::atomic<std::int64_t> dropped_empty_{0};
  std::atomic<std::int64_t> dropped_size_{0};
  std::atomic<std::int64_t> dropped_type_{0};
  std::atomic<std::int64_t> dropped_all_nan_{0};
  std::atomic<std::int64_t> dropped_unreadable_{0};
};

}  // namespace skylit::capture
