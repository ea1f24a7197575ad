#pragma once
// The last minutes of a node for the console's plots (docs/console.md): one sample a second of
// the sky's mean S per channel and the frame time and latency medians, so that a page opened now
// shows the past ten minutes at once.
#include <array>
#include <deque>
#include <mutex>
#include <optional>

#include <nlohmann/json.hpp>

namespace skylit::live {

class History {
 public:
  struct Sample {
    double t = 0;                                // steady seconds
    std::optional<std::array<double, 3>> mean_S;  // none before the first sky
    std::optional<double> frame_ms, latency_ms;   // none on a sky node
  };
  static constexpr double kSpan = 600;  // seconds kept
  static constexpr double kEvery = 1;   // seconds between samples

  // Whether a sample at `t` would be kept (a second since the last one): the caller need not
  // gather one every frame.
  bool due(double t) const {
    std::lock_guard lock(mutex_);
    return samples_.empty() || t - samples_.back().t >= kEvery;
  }
  // Keeps `sample` when a second has passed since the last one kept; true when kept.
  bool add(const Sample& sample) {
    std::lock_guard lock(mutex_);
    if (!samples_.empty() && sample.t - samples_.back().t < kEvery) return false;
    samples_.push_back(sample);
    while (!samples_.empty() && samples_.front().t < sample.t - kSpan) samples_.pop_front();
    return true;
  }
  // {"samples": [{"age_s", "S": [r, g, b] | null, "frame_ms", "latency_ms"}, ...]}, oldest first.
  nlohmann::json json(double now) const {
    std::lock_guard lock(mutex_);
    nlohmann::json list = nlohmann::json::array();
    for (const Sample& s : samples_) {
      list.push_back({{"age_s", now - s.t},
                      {"S", s.mean_S ? nlohmann::json(*s.mean_S) : nlohmann::json(nullptr)},
                      {"frame_ms", s.frame_ms ? nlohmann::json(*s.frame_ms) : nlohmann::json(nullptr)},
                      {"latency_ms", s.latency_ms ? nlohmann::json(*s.latency_ms) : nlohmann::json(nullptr)}});
    }
    return {{"samples", list}};
  }

 private:
  mutable std::mutex mutex_;
  std::deque<Sample> samples_;
};

// The mean over layers of S, per channel.
template <typename Vectors>
std::optional<std::array<double, 3>> mean_of(const Vectors& S) {
  if (S.empty()) return std::nullopt;
  std::array<double, 3> sum{0, 0, 0};
  for (const auto& v : S) {
    for (int c = 0; c < 3; ++c) sum[static_cast<std::size_t>(c)] += v[c];
  }
  for (double& x : sum) x /= static_cast<double>(S.size());
  return sum;
}

}  // namespace skylit::live
