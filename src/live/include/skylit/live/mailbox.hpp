#pragma once
// A latest-value mailbox between two threads: the writer replaces what is there, the reader
// takes the newest value. Nothing queues up, so a slow reader costs frames, never memory.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>

namespace skylit::live {

template <typename T>
class Mailbox {
 public:
  // Puts `value`, replacing an untaken one (counted as overwritten). Ignored once closed.
  void put(T value) {
    {
      std::lock_guard lock(mutex_);
      if (closed_) return;
      if (value_) ++overwritten_;
      value_ = std::move(value);
      ++version_;
    }
    ready_.notify_all();
  }

  // The newest value, if one arrived since the last take.
  std::optional<T> try_take() {
    std::lock_guard lock(mutex_);
    return std::exchange(value_, std::nullopt);
  }

  // Waits up to `timeout` for a value; empty on timeout or when closed.
  template <typename Rep, typename Period>
  std::optional<T> take(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock lock(mutex_);
    ready_.wait_for(lock, timeout, [&] { return value_.has_value() || closed_; });
    return std::exchange(value_, std::nullopt);
  }

  // Wakes every waiting reader; later puts are ignored.
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  // Values replaced before anyone took them (frames the reader was too slow for).
  std::uint64_t overwritten() const {
    std::lock_guard lock(mutex_);
    return overwritten_;
  }
  // Values put so far.
  std::uint64_t version() const {
    std::lock_guard lock(mutex_);
    return version_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::optional<T> value_;
  bool closed_ = false;
  std::uint64_t overwritten_ = 0;
  std::uint64_t version_ = 0;
};

// A value many threads read and one writes (the latest sky, the latest frame for /frame.jpg):
// readers get a copy of the newest one, with no notion of taking it.
template <typename T>
class Latest {
 public:
  void set(T value) {
    std::lock_guard lock(mutex_);
    value_ = std::move(value);
    ++version_;
  }
  std::optional<T> get() const {
    std::lock_guard lock(mutex_);
    return value_;
  }
  // The value with its version (how many sets so far): a reader that keeps something derived
  // from it (the console's JPEG) redoes it only for a newer version.
  std::pair<std::optional<T>, std::uint64_t> get_versioned() const {
    std::lock_guard lock(mutex_);
    return {value_, version_};
  }
  std::uint64_t version() const {
    std::lock_guard lock(mutex_);
    return version_;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<T> value_;
  std::uint64_t version_ = 0;
};

}  // namespace skylit::live
