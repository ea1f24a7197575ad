#pragma once
// Faults and pacing around any frame source: ReconnectingSource reopens a source that failed,
// with exponential backoff, while the rest of the service keeps running; RealtimeSource hands
// out a recording's frames at the pace they were recorded. Both take their clock from outside,
// so tests run them without sleeping.
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "skylit/capture/frame_source.hpp"

namespace skylit::capture {

// Seconds on a steady clock, and a way to wait. steady_clock() is the real one.
struct Clock {
  std::function<double()> now;
  std::function<void(double seconds)> sleep;
};
Clock steady_clock();

struct BackoffSettings {
  double initial_s = 0.5;  // wait before the first reopening attempt
  double max_s = 30.0;     // the wait doubles after each failed attempt, up to this
  // A source that delivers nothing for this long (seconds) is taken as failed and reopened
  // (a hung camera never reports an error); 0 turns this off.
  double silence_s = 0.0;
  // Status reports "stale" when no frame came for this long (seconds), or the source is down.
  double stale_after_s = 2.0;
};

struct ReconnectStatus {
  bool connected = false;         // a source is open
  bool stale = false;             // down, or no frame for stale_after_s
  std::int64_t reconnects = 0;    // successful reopenings
  std::int64_t failed_attempts = 0;
  double next_attempt_in_s = 0;   // while down: seconds until the next attempt
  std::string last_error;         // the last failure's message ("" when none yet)
};

class ReconnectingSource final : public FrameSource {
 public:
  using Opener = std::function<std::unique_ptr<FrameSource>()>;
  // Opens the source once now; errors from this first opening propagate (a wrong config is
  // reported at start, not retried for ever). Later failures, in next() or in reopening, are
  // caught and retried after initial_s, 2·initial_s, 4·initial_s, ... ≤ max_s; the wait resets
  // after a success. InputError for settings out of range.
  ReconnectingSource(Opener open, BackoffSettings settings, Clock clock = steady_clock());

  std::string describe() const override;
  bool set_exposure_time(double seconds) override;  // kept and applied again after reopening
  bool set_gain(double gain) override;
  FrameCounts counts() const override;  // this source's and every opened one's, added
  ReconnectStatus status() const;       // safe from any thread

 protected:
  FrameResult read(double timeout_s) override;
  std::optional<std::vector<Frame>> read_bracket(std::span<const double> exposure_times_s,
                                                 double timeout_s) override;

 private:
  void fail(const std::string& message, double now);  // drops the source, schedules a retry
  bool try_reopen(double now);

  Opener open_;
  BackoffSettings settings_;
  Clock clock_;
  mutable std::mutex mutex_;  // guards what status() and counts() read
  std::unique_ptr<FrameSource> source_;
  std::string description_;
  FrameCounts retired_counts_;  // of sources that failed
  double next_attempt_ = 0;
  double delay_ = 0;
  double last_frame_ = 0;       // clock time of the last frame (or of the last opening)
  std::int64_t reconnects_ = 0;
  std::int64_t failed_attempts_ = 0;
  std::string last_error_;
  std::optional<double> exposure_time_;
  std::optional<double> gain_;
};

// Holds each frame of a finite source until its time: frame k is handed out at
// t0 + (timestamp_k − timestamp_0) / speed on the clock, t0 when the first frame was read. A
// timestamp that goes back (a looping sequence) starts the count again.
class RealtimeSource final : public FrameSource {
 public:
  RealtimeSource(std::unique_ptr<FrameSource> source, double speed, Clock clock = steady_clock());
  std::string describe() const override { return source_->describe(); }
  bool set_exposure_time(double seconds) override { return source_->set_exposure_time(seconds); }
  bool set_gain(double gain) override { return source_->set_gain(gain); }
  FrameCounts counts() const override;

 protected:
  FrameResult read(double timeout_s) override;

 private:
  std::unique_ptr<FrameSource> source_;
  double speed_;
  Clock clock_;
  std::optional<Frame> pending_;
  std::optional<double> anchor_clock_;
  double anchor_timestamp_ = 0;
};

}  // namespace skylit::capture
