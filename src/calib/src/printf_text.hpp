#pragma once
// One number formatted by a printf pattern ("%.2f px"), for the calibration reports and errors.
#include <algorithm>
#include <cstdio>
#include <string>

namespace skylit::calib {

inline std::string format(const char* pattern, double value) {
  const int length = std::snprintf(nullptr, 0, pattern, value);
  std::string text(static_cast<std::size_t>(std::max(length, 0)), '\0');
  std::snprintf(text.data(), text.size() + 1, pattern, value);
  return text;
}

}  // namespace skylit::calib
