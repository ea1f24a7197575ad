#pragma once
// Frame-time statistics over a sliding window (the last N frames): percentiles and rate, in
// constant memory for a service that runs all day.
#include <cstddef>
#include <vector>

namespace skylit::live {

class FrameTimes {
 public:
  explicit FrameTimes(std::size_t window = 600);

  // One frame: how long it took (seconds) and when it ended (seconds, steady clock).
  void add(double duration, double end_time);

  std::size_t count() const { return filled_; }
  // Percentile q in [0, 1] of the durations in the window (nearest rank); 0 when empty.
  double percentile(double q) const;
  // Frames per second over the window (frames / time between the first and last end); 0 with
  // fewer than two frames.
  double rate() const;

 private:
  std::vector<double> durations_, ends_;
  std::size_t next_ = 0, filled_ = 0;
};

}  // namespace skylit::live
