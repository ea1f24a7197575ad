#include "skylit/capture/reconnecting_source.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <thread>

#include "skylit/base/error.hpp"

namespace skylit::capture {
namespace {

void check_setting(const std::string& field, double value, double minimum, const std::string& fix) {
  if (!std::isfinite(value) || value < minimum) {
    throw InputError(input_message("", -1, -1, field, "got " + std::to_string(value), fix));
  }
}

}  // namespace

Clock steady_clock() {
  const auto origin = std::chrono::steady_clock::now();
  return Clock{[origin] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - origin).count(); },
               [](double seconds) {
                 if (seconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
               }};
}

// ---------------------------------------------------------------------------------------------

ReconnectingSource::ReconnectingSource(Opener open, BackoffSettings settings, Clock clock)
    : open_(std::move(open)), settings_(settings), clock_(std::move(clock)) {
  check_setting("reconnect.initial", settings_.initial_s, 1e-3, "give the first wait in seconds, e.g. 0.5");
  check_setting("reconnect.max", settings_.max_s, settings_.initial_s,
                "give the longest wait in seconds, at least reconnect.initial, e.g. 30");
  check_setting("reconnect.silence", settings_.silence_s, 0.0,
                "give seconds without a frame after which the source is reopened, or 0 for never");
  check_setting("reconnect.stale_after", settings_.stale_after_s, 0.0,
                "give seconds without a frame after which the status says stale, e.g. 2");
  delay_ = settings_.initial_s;
  source_ = open_();
  description_ = source_->describe();
  last_frame_ = clock_.now();
}

std::string ReconnectingSource::describe() const {
  const std::lock_guard lock(mutex_);
  return description_;
}

bool ReconnectingSource::set_exposure_time(double seconds) {
  exposure_time_ = seconds;
  return source_ ? source_->set_exposure_time(seconds) : true;
}

bool ReconnectingSource::set_gain(double gain) {
  gain_ = gain;
  return source_ ? source_->set_gain(gain) : true;
}

FrameCounts ReconnectingSource::counts() const {
  const FrameCounts own = FrameSource::counts();
  const std::lock_guard lock(mutex_);
  FrameCounts total = retired_counts_;
  if (source_) total += source_->counts();
  // Frames pass the inner source's checks and then this one's (which catch a size that changed
  // across a reopening): delivered is what came out here, drops are both.
  total.delivered = own.delivered;
  total.dropped_empty += own.dropped_empty;
  total.dropped_size += own.dropped_size;
  total.dropped_type += own.dropped_type;
  total.dropped_all_nan += own.dropped_all_nan;
  total.dropped_unreadable += own.dropped_unreadable;
  return total;
}

ReconnectStatus ReconnectingSource::status() const {
  const std::lock_guard lock(mutex_);
  const double now = clock_.now();
  ReconnectStatus status;
  status.connected = source_ != nullptr;
  status.stale = !source_ || now - last_frame_ > settings_.stale_after_s;
  status.reconnects = reconnects_;
  status.failed_attempts = failed_attempts_;
  status.next_attempt_in_s = source_ ? 0.0 : std::max(0.0, next_attempt_ - now);
  status.last_error = last_error_;
  return status;
}

void ReconnectingSource::fail(const std::string& message, double now) {
  const std::lock_guard lock(mutex_);
  if (source_) {
    retired_counts_ += source_->counts();
    source_.reset();  // closes the device now, before the wait
    delay_ = settings_.initial_s;
  } else {
    ++failed_attempts_;
  }
  last_error_ = message;
  next_attempt_ = now + delay_;
  delay_ = std::min(delay_ * 2.0, settings_.max_s);
}

bool ReconnectingSource::try_reopen(double now) {
  std::unique_ptr<FrameSource> source;
  try {
    source = open_();
    if (exposure_time_) source->set_exposure_time(*exposure_time_);
    if (gain_) source->set_gain(*gain_);
  } catch (const std::exception& e) {
    fail(e.what(), now);
    return false;
  }
  const std::lock_guard lock(mutex_);
  source_ = std::move(source);
  description_ = source_->describe();
  ++reconnects_;
  delay_ = settings_.initial_s;
  last_frame_ = now;
  return true;
}

FrameResult ReconnectingSource::read(double timeout_s) {
  const double start = clock_.now();
  if (!source_) {
    const double wait = next_attempt_ - start;
    if (wait > 0) {
      if (wait > timeout_s) {
        clock_.sleep(timeout_s);
        return {FrameStatus::NotYet, {}};
      }
      clock_.sleep(wait);
    }
    if (!try_reopen(clock_.now())) return {FrameStatus::NotYet, {}};
  }
  const double remaining = std::max(0.0, timeout_s - (clock_.now() - start));
  FrameResult result;
  try {
    result = source_->next(remaining);
  } catch (const std::exception& e) {
    fail(e.what(), clock_.now());
    return {FrameStatus::NotYet, {}};
  }
  const double now = clock_.now();
  if (result.status == FrameStatus::Ready) {
    const std::lock_guard lock(mutex_);
    last_frame_ = now;
  } else if (result.status == FrameStatus::NotYet && settings_.silence_s > 0 &&
             now - last_frame_ > settings_.silence_s) {
    fail("no frame for " + std::to_string(now - last_frame_) + " s", now);
  }
  return result;
}

std::optional<std::vector<Frame>> ReconnectingSource::read_bracket(std::span<const double> exposure_times_s,
                                                                   double timeout_s) {
  if (!source_) {
    // Down: the bracket waits for the source like a frame would.
    const FrameResult probe = read(timeout_s);
    if (!source_) return std::vector<Frame>{};
    (void)probe;  // a frame taken while reconnecting is not part of the bracket
  }
  try {
    std::optional<std::vector<Frame>> frames = source_->bracket(exposure_times_s, timeout_s);
    if (frames && !frames->empty()) {
      const std::lock_guard lock(mutex_);
      last_frame_ = clock_.now();
    }
    return frames;
  } catch (const std::exception& e) {
    fail(e.what(), clock_.now());
    return std::vector<Frame>{};
  }
}

// ---------------------------------------------------------------------------------------------

RealtimeSource::RealtimeSource(std::unique_ptr<FrameSource> source, double speed, Clock clock)
    : source_(std::move(source)), speed_(speed), clock_(std::move(clock)) {
  if (!std::isfinite(speed_) || speed_ <= 0) {
    throw InputError(input_message("", -1, -1, "realtime", "got " + std::to_string(speed_),
                                   "give a positive speed: 1 plays at the recorded pace, 10 ten times faster"));
  }
}

FrameCounts RealtimeSource::counts() const {
  FrameCounts total = source_->counts();
  const FrameCounts own = FrameSource::counts();
  total.delivered = own.delivered;
  return total;
}

FrameResult RealtimeSource::read(double timeout_s) {
  const double start = clock_.now();
  if (!pending_) {
    FrameResult result = source_->next(timeout_s);
    if (result.status != FrameStatus::Ready) return result;
    pending_ = std::move(result.frame);
  }
  const double now = clock_.now();
  if (!anchor_clock_ || pending_->timestamp < anchor_timestamp_) {
    anchor_clock_ = now;
    anchor_timestamp_ = pending_->timestamp;
  }
  const double due = *anchor_clock_ + (pending_->timestamp - anchor_timestamp_) / speed_;
  if (due > now) {
    const double budget = std::max(0.0, timeout_s - (now - start));
    if (due - now > budget) {
      clock_.sleep(budget);
      return {FrameStatus::NotYet, {}};
    }
    clock_.sleep(due - now);
  }
  FrameResult result{FrameStatus::Ready, std::move(*pending_)};
  pending_.reset();
  return result;
}

}  // namespace skylit::capture
