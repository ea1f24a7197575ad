#include "skylit/base/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <utility>

namespace skylit {
namespace {

constexpr auto kTerminalInterval = std::chrono::milliseconds(100);  // at most ~10 redraws/s
constexpr auto kLogInterval = std::chrono::seconds(30);             // a plain line at least this often
constexpr int kBarWidth = 20;

}  // namespace

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds)) return "?";
  seconds = std::max(0.0, seconds);
  char text[64];
  if (seconds < 59.95) {
    std::snprintf(text, sizeof text, "%.1f s", seconds);
    return text;
  }
  const long long whole_seconds = std::llround(seconds);
  if (whole_seconds < 3600) {
    std::snprintf(text, sizeof text, "%lld min %02lld s", whole_seconds / 60, whole_seconds % 60);
    return text;
  }
  const long long whole_minutes = std::llround(seconds / 60.0);
  std::snprintf(text, sizeof text, "%lld h %02lld min", whole_minutes / 60, whole_minutes % 60);
  return text;
}

Progress::Progress(std::string label, std::int64_t total, std::FILE* out)
    : label_(std::move(label)),
      total_(std::max<std::int64_t>(total, 0)),
      out_(out),
      tty_(out != nullptr && ::isatty(::fileno(out)) == 1),
      start_(std::chrono::steady_clock::now()),
      last_report_(start_) {
  if (tty_) report(true);
}

Progress::~Progress() {
  // Leave the terminal on a fresh line if the work stopped early (an exception, say).
  if (!finished_ && tty_ && out_ != nullptr) {
    std::fputc('\n', out_);
    std::fflush(out_);
  }
}

void Progress::advance(std::int64_t units) {
  done_ = std::min(total_, done_ + std::max<std::int64_t>(units, 0));
  report(false);
}

void Progress::finish() {
  if (finished_ || out_ == nullptr) {
    finished_ = true;
    return;
  }
  if (tty_) {
    done_ = total_;
    report(true);
    std::fputc('\n', out_);
  }
  std::fprintf(out_, "%s: done in %s\n", label_.c_str(), format_duration(elapsed_seconds()).c_str());
  std::fflush(out_);
  finished_ = true;
}

double Progress::elapsed_seconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::report(bool force) {
  if (out_ == nullptr || finished_) return;
  const auto now = std::chrono::steady_clock::now();
  const int percent =
      total_ > 0 ? static_cast<int>(100 * done_ / total_) : 100;
  std::string eta;
  if (done_ > 0 && done_ < total_) {
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    eta = "ETA " + format_duration(elapsed * static_cast<double>(total_ - done_) /
                                   static_cast<double>(done_));
  }
  if (tty_) {
    if (!force && now - last_report_ < kTerminalInterval && done_ < total_) return;
    const int filled = total_ > 0 ? static_cast<int>(kBarWidth * done_ / total_) : kBarWidth;
    const std::string bar = std::string(static_cast<std::size_t>(filled), '#') +
                            std::string(static_cast<std::size_t>(kBarWidth - filled), '.');
    // Trailing spaces wipe what a longer previous line left behind.
    std::fprintf(out_, "\r%s [%s] %3d%% %lld/%lld %s    ", label_.c_str(), bar.c_str(), percent,
                 static_cast<long long>(done_), static_cast<long long>(total_), eta.c_str());
  } else {
    const bool new_decade = percent / 10 > last_percent_ / 10 && percent > 0;
    if (!force && !new_decade && now - last_report_ < kLogInterval) return;
    if (done_ == total_ && last_percent_ == 100) return;  // said already; finish() says the rest
    std::fprintf(out_, "%s: %d%% (%lld/%lld)%s%s\n", label_.c_str(), percent,
                 static_cast<long long>(done_), static_cast<long long>(total_),
                 eta.empty() ? "" : ", ", eta.c_str());
  }
  std::fflush(out_);
  last_report_ = now;
  last_percent_ = percent;
}

}  // namespace skylit
