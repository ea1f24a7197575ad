#pragma once
// The service's counters and timings, kept by its threads and read by /status and /metrics:
// frame and error counts, each source's activity and frame rate, when camera frames arrived, and
// the render thread's stage timer, which feeds the frame statistics (FrameTimes).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>
#include <vector>

namespace skylit::live {

using Clock = std::chrono::steady_clock;

inline double now_seconds() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

// A source's health for /status: when its last frame came, whether it has ended.
struct SourceActivity {
  std::atomic<double> last_frame{-1};   // steady seconds; < 0: none yet
  std::atomic<bool> ended{false};       // a finite source has no more frames
  void frame() {
    last_frame = now_seconds();
    ended = false;
  }
};

// A frame rate from frame timestamps: the median interval between consecutive frames of the
// first kRateIntervals (a frame dropped or late moves a median little).
struct FrameRate {
  std::optional<double> hz;
  bool settled = false;   // measured over kRateIntervals intervals (or the source has ended)
};
constexpr std::size_t kRateIntervals = 8;

class FrameRateMeter {
 public:
  void add(double timestamp) {
    std::lock_guard lock(mutex_);
    if (intervals_.size() >= kRateIntervals) return;
    if (last_ && timestamp > *last_) intervals_.push_back(timestamp - *last_);
    last_ = timestamp;
  }
  void end() {
    std::lock_guard lock(mutex_);
    ended_ = true;
  }
  FrameRate rate() const {
    std::lock_guard lock(mutex_);
    FrameRate rate;
    rate.settled = ended_ || intervals_.size() >= kRateIntervals;
    if (intervals_.empty()) return rate;
    std::vector<double> sorted = intervals_;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    rate.hz = 1.0 / sorted[sorted.size() / 2];
    return rate;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<double> last_;
  std::vector<double> intervals_;
  bool ended_ = false;
};

// When the camera thread received each of the last frames (steady seconds), by frame timestamp:
// the render thread's frame has waited in the mailbox since then.
class ArrivalTimes {
 public:
  void put(double frame_timestamp, double arrived) {
    std::lock_guard lock(mutex_);
    entries_[next_] = {frame_timestamp, arrived};
    next_ = (next_ + 1) % entries_.size();
  }
  std::optional<double> find(double frame_timestamp) const {
    std::lock_guard lock(mutex_);
    for (const auto& [timestamp, arrived] : entries_) {
      if (arrived >= 0 && timestamp == frame_timestamp) return arrived;
    }
    return std::nullopt;
  }

 private:
  static std::array<std::pair<double, double>, 8> empty_entries() {
    std::array<std::pair<double, double>, 8> entries;
    entries.fill({0.0, -1.0});
    return entries;
  }
  mutable std::mutex mutex_;
  std::array<std::pair<double, double>, 8> entries_ = empty_entries();  // (frame timestamp, arrival); arrival < 0: unused
  std::size_t next_ = 0;
};

struct Counters {
  std::atomic<std::int64_t> frames{0};
  std::atomic<std::int64_t> camera_frames{0};
  std::atomic<std::int64_t> sky_frames{0};
  std::atomic<std::int64_t> sky_estimates{0};
  std::atomic<std::int64_t> blends_run{0};
  std::atomic<std::int64_t> blends_skipped{0};
  // The building's light summed for a new sky: ahead on the sky thread, or by a compositor in the
  // frame that took the sky (a sky that came without its sums).
  std::atomic<std::int64_t> building_light_sky_thread{0};
  std::atomic<std::int64_t> building_light_in_frame{0};
  // The bytes the building's light map holds for those sums (render.light_map_precision), once
  // the compositor has it; 0 without a light map.
  std::atomic<std::int64_t> light_map_bytes{0};
  std::atomic<std::int64_t> pose_missing{0};
  std::atomic<std::int64_t> frames_without_sky{0};
  std::atomic<std::int64_t> sky_errors{0};
  std::atomic<std::int64_t> camera_errors{0};
};

// A summary's sum and count since start (Prometheus' _sum and _count).
struct RunningTotal {
  double sum = 0;
  std::int64_t count = 0;
  void add(double value) {
    sum += value;
    ++count;
  }
};

// Milliseconds from `start` to now.
inline double milliseconds_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The render thread's timed stages, as /status reports them (stage_ms_p50).
enum class Stage { SunShadow, Upload, Blend, Composite, Record };
inline constexpr std::size_t kStageCount = 5;

// One frame's stage times, summed while it is drawn; the render thread keeps them in its
// FrameTimes once the frame is done (a frame left undrawn keeps none).
struct FrameStageTimes {
  explicit FrameStageTimes(bool wait_for_gpu) : profile(wait_for_gpu) {}
  bool profile;                               // ServiceOptions::profile: wait for the GPU at a stage's end
  Clock::time_point start = Clock::now();     // the frame's
  std::array<double, kStageCount> ms{};
  std::array<bool, kStageCount> ran{};        // timed this frame
  double at(Stage stage) const { return ms[static_cast<std::size_t>(stage)]; }
  bool timed(Stage stage) const { return ran[static_cast<std::size_t>(stage)]; }
};

// Times one stage from its construction to the end of its scope, into the frame's time for
// `stage` (nullopt: timed for no stage, only waited for under --profile). Under --profile the
// stages that leave GL work queued (the sun's map, the upload and the blend) first wait for it;
// the composite and the recording are timed as they return.
class StageTimer {
 public:
  StageTimer(FrameStageTimes& times, std::optional<Stage> stage)
      : times_(times), stage_(stage), start_(Clock::now()) {}
  ~StageTimer();
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

  // The stage had nothing to do this frame: neither waited for nor timed.
  void cancel() { cancelled_ = true; }

 private:
  FrameStageTimes& times_;
  std::optional<Stage> stage_;
  Clock::time_point start_;
  bool cancelled_ = false;
};

}  // namespace skylit::live
