#pragma once
// Progress of long work: a bar with ETA on a terminal, plain lines otherwise.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace skylit {

class Progress {
 public:
  // `total` units of work; `label` prefixes every line. Writes to `out` (stderr by default).
  Progress(std::string label, std::int64_t total, std::FILE* out = stderr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::int64_t units = 1);  // thread-compatible, not thread-safe
  void finish();                          // final line with the elapsed time
  double elapsed_seconds() const;

 private:
  void report(bool force);
  std::string label_;
  std::int64_t total_;
  std::int64_t done_ = 0;
  std::FILE* out_;
  bool tty_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_report_;
  int last_percent_ = -1;
};

std::string format_duration(double seconds);  // "1 h 02 min", "3 min 05 s", "4.2 s"

}  // namespace skylit
