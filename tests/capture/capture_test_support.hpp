#pragma once
// Shared helpers for the frame-source tests: the tests' temporary directory, a clock that only
// moves when told to, and a scripted source that fails on demand.
#include <gtest/gtest.h>
#include <unistd.h>

#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "skylit/capture/frame_source.hpp"
#include "skylit/capture/reconnecting_source.hpp"
#include "../support/temp_dir.hpp"

namespace skylit::capture::testing {

using skylit::test::TempDir;

// Time moves only through sleep() and advance(); every sleep is recorded.
struct FakeTime {
  double now = 0;
  std::vector<double> sleeps;
  void advance(double seconds) { now += seconds; }
  Clock clock() {
    return Clock{[this] { return now; },
                 [this](double seconds) {
                   sleeps.push_back(seconds);
                   if (seconds > 0) now += seconds;
                 }};
  }
};

// Hands out scripted results; throws CaptureError when `fail_next` is set.
class ScriptedSource final : public FrameSource {
 public:
  explicit ScriptedSource(std::string name = "scripted") : name_(std::move(name)) {}
  std::deque<FrameResult> script;
  bool fail_next = false;
  std::optional<double> exposure_time;
  std::string describe() const override { return name_; }
  bool set_exposure_time(double seconds) override {
    exposure_time = seconds;
    return true;
  }

 protected:
  FrameResult read(double /*timeout_s*/) override {
    if (fail_next) throw CaptureError(name_ + ": unplugged");
    if (script.empty()) return {FrameStatus::NotYet, {}};
    FrameResult result = std::move(script.front());
    script.pop_front();
    return result;
  }

 private:
  std::string name_;
};

inline FrameResult ready(cv::Mat image, double timestamp = 0) {
  FrameResult result{FrameStatus::Ready, {}};
  result.frame.image = std::move(image);
  result.frame.timestamp = timestamp;
  return result;
}

inline cv::Mat grey(int width, int height, int value) { return cv::Mat(height, width, CV_8UC3, cv::Scalar::all(value)); }

}  // namespace skylit::capture::testing
