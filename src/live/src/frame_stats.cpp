#include "skylit/live/frame_stats.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace skylit::live {

FrameTimes::FrameTimes(std::size_t window) : durations_(window), ends_(window) {
  if (window == 0) throw std::invalid_argument("FrameTimes: window must be at least 1");
}

void FrameTimes::add(double duration, double end_time) {
  durations_[next_] = duration;
  ends_[next_] = end_time;
  next_ = (next_ + 1) % durations_.size();
  filled_ = std::min(filled_ + 1, durations_.size());
}

double FrameTimes::percentile(double q) const {
  if (filled_ == 0) return 0.0;
  std::vector<double> sorted(durations_.begin(), durations_.begin() + static_cast<std::ptrdiff_t>(filled_));
  std::sort(sorted.begin(), sorted.end());
  const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(filled_));
  const auto index = static_cast<std::size_t>(std::max(1.0, rank)) - 1;
  return sorted[std::min(index, filled_ - 1)];
}

double FrameTimes::rate() const {
  if (filled_ < 2) return 0.0;
  // Oldest end in the window: at next_ once the ring has wrapped, else at 0.
  const std::size_t oldest = filled_ == durations_.size() ? next_ : 0;
  const std::size_t newest = (next_ + durations_.size() - 1) % durations_.size();
  const double span = ends_[newest] - ends_[oldest];
  return span > 0.0 ? static_cast<double>(filled_ - 1) / span : 0.0;
}

}  // namespace skylit::live
