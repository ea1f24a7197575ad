#include "skylit/capture/frame_source.hpp"

#include <chrono>
#include <cmath>

#include <opencv2/core.hpp>

namespace skylit::capture {
namespace {

bool accepted_type(int type) {
  const int depth = CV_MAT_DEPTH(type);
  const int channels = CV_MAT_CN(type);
  return (depth == CV_8U || depth == CV_16U || depth == CV_32F) && (channels == 1 || channels == 3);
}

// True when no element of a float image is finite (NaN or ±Inf everywhere: nothing to measure).
bool no_finite_value(const cv::Mat& image) {
  for (int y = 0; y < image.rows; ++y) {
    const float* row = image.ptr<float>(y);
    const auto count = static_cast<std::size_t>(image.cols) * static_cast<std::size_t>(image.channels());
    for (std::size_t i = 0; i < count; ++i) {
      if (std::isfinite(row[i])) return false;
    }
  }
  return true;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

FrameCounts& FrameCounts::operator+=(const FrameCounts& other) {
  delivered += other.delivered;
  dropped_empty += other.dropped_empty;
  dropped_size += other.dropped_size;
  dropped_type += other.dropped_type;
  dropped_all_nan += other.dropped_all_nan;
  dropped_unreadable += other.dropped_unreadable;
  return *this;
}

FrameProblem check_frame(const cv::Mat& image, FrameChecks& checks) {
  if (image.empty()) return FrameProblem::Empty;
  if (!accepted_type(image.type())) return FrameProblem::Type;
  if (checks.type && image.type() != *checks.type) return FrameProblem::Type;
  if (checks.size && image.size() != *checks.size) return FrameProblem::Size;
  if (image.depth() == CV_32F && no_finite_value(image)) return FrameProblem::AllNaN;
  if (checks.lock_to_first) {
    if (!checks.size) checks.size = image.size();
    if (!checks.type) checks.type = image.type();
  }
  return FrameProblem::None;
}

bool FrameSource::accept(Frame& frame) {
  switch (check_frame(frame.image, checks_)) {
    case FrameProblem::None:
      break;
    case FrameProblem::Empty:
      dropped_empty_.fetch_add(1, std::memory_order_relaxed);
      return false;
    case FrameProblem::Size:
      dropped_size_.fetch_add(1, std::memory_order_relaxed);
      return false;
    case FrameProblem::Type:
      dropped_type_.fetch_add(1, std::memory_order_relaxed);
      return false;
    case FrameProblem::AllNaN:
      dropped_all_nan_.fetch_add(1, std::memory_order_relaxed);
      return false;
  }
  frame.source = name();  // the outermost source names it (a wrapper's configured name wins)
  delivered_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

FrameResult FrameSource::next(double timeout_s) {
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const double remaining = std::max(0.0, timeout_s - seconds_since(start));
    FrameResult result = read(remaining);
    if (result.status != FrameStatus::Ready) return result;
    if (accept(result.frame)) return result;
    // A malformed frame: try the next one while time remains.
    if (seconds_since(start) >= timeout_s) return {FrameStatus::NotYet, {}};
  }
}

std::optional<std::vector<Frame>> FrameSource::bracket(std::span<const double> exposure_times_s,
                                                       double timeout_s) {
  std::optional<std::vector<Frame>> frames = read_bracket(exposure_times_s, timeout_s);
  if (!frames) return frames;
  std::vector<Frame> good;
  for (Frame& frame : *frames) {
    if (accept(frame)) good.push_back(std::move(frame));
  }
  return good;
}

bool FrameSource::set_exposure_time(double /*seconds*/) { return false; }
bool FrameSource::set_gain(double /*gain*/) { return false; }

std::optional<std::vector<Frame>> FrameSource::read_bracket(std::span<const double> /*exposure_times_s*/,
                                                            double /*timeout_s*/) {
  return std::nullopt;
}

FrameCounts FrameSource::counts() const {
  FrameCounts counts;
  counts.delivered = delivered_.load(std::memory_order_relaxed);
  counts.dropped_empty = dropped_empty_.load(std::memory_order_relaxed);
  counts.dropped_size = dropped_size_.load(std::memory_order_relaxed);
  counts.dropped_type = dropped_type_.load(std::memory_order_relaxed);
  counts.dropped_all_nan = dropped_all_nan_.load(std::memory_order_relaxed);
  counts.dropped_unreadable = dropped_unreadable_.load(std::memory_order_relaxed);
  return counts;
}

}  // namespace skylit::capture
