// Two cameras paired by timestamp into one side-by-side stereo frame, and the split and join of
// such frames.
#include "skylit/capture/paired_source.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/core.hpp>

#include "skylit/base/error.hpp"

namespace skylit::capture {
namespace {

// "640×480 CV_8UC3".
std::string size_and_type(const cv::Mat& image) {
  if (image.empty()) return "empty";
  return std::to_string(image.cols) + "×" + std::to_string(image.rows) + " " + cv::typeToString(image.type());
}

std::string milliseconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", seconds * 1e3);
  return text;
}

double seconds_since_start(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

StereoHalves split_side_by_side(const cv::Mat& frame) {
  if (frame.empty()) {
    throw InputError(input_message("", -1, -1, "stereo frame", "the frame is empty",
                                   "give the stereo camera's side-by-side frame"));
  }
  if (frame.cols % 2 != 0) {
    throw InputError(input_message("", -1, -1, "stereo frame",
                                   "a side-by-side frame has two halves of equal width; this one is " +
                                       std::to_string(frame.cols) + " pixels wide",
                                   "give the stereo camera's side-by-side frame (a mono camera's frame is not one)"));
  }
  const int half = frame.cols / 2;
  return {frame.colRange(0, half), frame.colRange(half, frame.cols)};
}

cv::Mat join_side_by_side(const cv::Mat& left, const cv::Mat& right) {
  if (left.empty() || right.empty() || left.size() != right.size() || left.type() != right.type()) {
    throw InputError(input_message("", -1, -1, "stereo frame",
                                   "the left image (" + size_and_type(left) + ") and the right image (" +
                                       size_and_type(right) + ") differ",
                                   "give two images of the same size and type"));
  }
  cv::Mat joined;
  cv::hconcat(left, right, joined);
  return joined;
}

// ---------------------------------------------------------------------------------------------

PairedSource::PairedSource(std::unique_ptr<FrameSource> left, std::unique_ptr<FrameSource> right, double tolerance_s,
                           FrameChecks checks)
    : FrameSource(checks), left_(std::move(left)), right_(std::move(right)), tolerance_s_(tolerance_s) {
  if (!left_ || !right_) {
    throw InputError(input_message("", -1, -1, left_ ? "source.right" : "source.left", "missing",
                                   "give both cameras of the pair"));
  }
  if (!std::isfinite(tolerance_s_) || tolerance_s_ <= 0) {
    throw InputError(input_message("", -1, -1, "source.tolerance_ms", "got " + milliseconds_text(tolerance_s_) + " ms",
                                   "give a positive tolerance below half a frame interval, e.g. 5 ms at 90 Hz"));
  }
}

std::string PairedSource::describe() const {
  return "pair (" + left_->name() + " | " + right_->name() + ", ±" + milliseconds_text(tolerance_s_) + " ms)";
}

bool PairedSource::set_exposure_time(double seconds) {
  const bool left_took = left_->set_exposure_time(seconds);
  const bool right_took = right_->set_exposure_time(seconds);
  return left_took && right_took;
}

bool PairedSource::set_gain(double gain) {
  const bool left_took = left_->set_gain(gain);
  const bool right_took = right_->set_gain(gain);
  return left_took && right_took;
}

FrameCounts PairedSource::counts() const {
  FrameCounts total = left_->counts();
  total += right_->counts();
  // A pair counts once: what came out here. The sides' drops stay, since either camera's bad
  // frames cost pairs.
  const FrameCounts own = FrameSource::counts();
  total.delivered = 0;
  total += own;
  return total;
}

PairCounts PairedSource::pair_counts() const {
  return PairCounts{.paired = paired_.load(std::memory_order_relaxed),
                    .unpaired_left = unpaired_left_.load(std::memory_order_relaxed),
                    .unpaired_right = unpaired_right_.load(std::memory_order_relaxed)};
}

FrameResult PairedSource::end_of_stream() {
  if (left_waiting_) unpaired_left_.fetch_add(1, std::memory_order_relaxed);
  if (right_waiting_) unpaired_right_.fetch_add(1, std::memory_order_relaxed);
  left_waiting_.reset();
  right_waiting_.reset();
  ended_ = true;
  return {FrameStatus::EndOfStream, {}};
}

Frame PairedSource::join(Frame& left, Frame& right) {
  if (left.image.size() != right.image.size() || left.image.type() != right.image.type()) {
    unpaired_left_.fetch_add(1, std::memory_order_relaxed);
    unpaired_right_.fetch_add(1, std::memory_order_relaxed);
    throw InputError(input_message("", -1, -1, "source", "the pair's cameras deliver different frames: left " +
                                                            left_->name() + " " + size_and_type(left.image) +
                                                            ", right " + right_->name() + " " +
                                                            size_and_type(right.image),
                                   "set both cameras to the same mode (width, height, pixel format)"));
  }
  Frame frame;
  cv::hconcat(left.image, right.image, frame.image);
  frame.timestamp = 0.5 * (left.timestamp + right.timestamp);
  frame.sequence = sequence_++;
  frame.exposure_time = left.exposure_time;
  frame.gain = left.gain;
  frame.utc = left.utc;
  return frame;
}

FrameResult PairedSource::read(double timeout_s) {
  if (ended_) return {FrameStatus::EndOfStream, {}};
  const auto start = std::chrono::steady_clock::now();
  const auto remaining = [&] { return std::max(0.0, timeout_s - seconds_since_start(start)); };
  for (;;) {
    // One frame waits per side; a side that has none yet is asked, the other is not read ahead,
    // so a side that is down (reconnecting) holds the other at its newest frame taken.
    if (!left_waiting_) {
      FrameResult result = left_->next(remaining());
      if (result.status == FrameStatus::EndOfStream) return end_of_stream();
      if (result.status == FrameStatus::NotYet) return {FrameStatus::NotYet, {}};
      left_waiting_ = std::move(result.frame);
    }
    if (!right_waiting_) {
      FrameResult result = right_->next(remaining());
      if (result.status == FrameStatus::EndOfStream) return end_of_stream();
      if (result.status == FrameStatus::NotYet) return {FrameStatus::NotYet, {}};
      right_waiting_ = std::move(result.frame);
    }
    const double gap = left_waiting_->timestamp - right_waiting_->timestamp;
    if (std::abs(gap) <= tolerance_s_) {
      Frame left = std::move(*left_waiting_);
      Frame right = std::move(*right_waiting_);
      left_waiting_.reset();
      right_waiting_.reset();
      FrameResult result{FrameStatus::Ready, join(left, right)};
      paired_.fetch_add(1, std::memory_order_relaxed);
      return result;
    }
    // The older frame's partner would have come before the newer frame of the other side, and
    // timestamps increase per source: it can no longer come.
    if (gap < 0) {
      left_waiting_.reset();
      unpaired_left_.fetch_add(1, std::memory_order_relaxed);
    } else {
      right_waiting_.reset();
      unpaired_right_.fetch_add(1, std::memory_order_relaxed);
    }
    if (remaining() <= 0) return {FrameStatus::NotYet, {}};
  }
}

}  // namespace skylit::capture
