// Reopening a failed source with exponential backoff, and real-time pacing, on a fake clock.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "capture_test_support.hpp"
#include "skylit/base/error.hpp"

namespace {

using namespace skylit::capture;
using skylit::capture::testing::FakeTime;
using skylit::capture::testing::grey;
using skylit::capture::testing::ready;
using skylit::capture::testing::ScriptedSource;

// Opens ScriptedSources while `plugged`, throws CaptureError otherwise; records when.
struct Camera {
  explicit Camera(FakeTime* clock_time) : time(clock_time) {}
  FakeTime* time;
  bool plugged = true;
  std::vector<double> attempts;
  ScriptedSource* current = nullptr;
  int opened = 0;
  ReconnectingSource::Opener opener() {
    return [this]() -> std::unique_ptr<FrameSource> {
      attempts.push_back(time->now);
      if (!plugged) throw CaptureError("camera absent");
      auto source = std::make_unique<ScriptedSource>("camera #" + std::to_string(++opened));
      current = source.get();
      return source;
    };
  }
};

BackoffSettings backoff(double initial, double max) {
  BackoffSettings settings;
  settings.initial_s = initial;
  settings.max_s = max;
  settings.stale_after_s = 2.0;
  return settings;
}

TEST(ReconnectingSource, ReopensWithDoublingWaitsCappedAtMax) {
  FakeTime time;
  Camera camera(&time);
  ReconnectingSource source(camera.opener(), backoff(0.5, 4.0), time.clock());
  ASSERT_EQ(camera.attempts.size(), 1u);
  camera.current->script = {ready(grey(4, 4, 1), 0)};
  ASSERT_EQ(source.next(1.0).status, FrameStatus::Ready);

  // Unplugged: the next read fails, the source is dropped and a retry is scheduled.
  camera.current->fail_next = true;
  camera.plugged = false;
  EXPECT_EQ(source.next(0.0).status, FrameStatus::NotYet);
  ReconnectStatus status = source.status();
  EXPECT_FALSE(status.connected);
  EXPECT_TRUE(status.stale);
  EXPECT_EQ(status.last_error, "camera #1: unplugged");
  EXPECT_DOUBLE_EQ(status.next_attempt_in_s, 0.5);

  // Each call waits (on the fake clock) for the next attempt: 0.5, 1, 2, 4, 4, 4 s apart.
  for (int k = 0; k < 6; ++k) EXPECT_EQ(source.next(10.0).status, FrameStatus::NotYet);
  const std::vector<double> expected{0.0, 0.5, 1.5, 3.5, 7.5, 11.5, 15.5};
  ASSERT_EQ(camera.attempts.size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_DOUBLE_EQ(camera.attempts[i], expected[i]) << i;
  EXPECT_EQ(source.status().failed_attempts, 6);
  EXPECT_EQ(source.status().last_error, "camera absent");

  // Plugged in again: the next attempt (4 s later) succeeds and frames flow.
  camera.plugged = true;
  FrameResult result = source.next(10.0);
  EXPECT_DOUBLE_EQ(camera.attempts.back(), 19.5);
  EXPECT_EQ(result.status, FrameStatus::NotYet);  // the new camera has no frame yet
  camera.current->script = {ready(grey(4, 4, 2), 1)};
  result = source.next(1.0);
  ASSERT_EQ(result.status, FrameStatus::Ready);
  EXPECT_EQ(result.frame.image.at<cv::Vec3b>(0, 0)[0], 2);
  status = source.status();
  EXPECT_TRUE(status.connected);
  EXPECT_FALSE(status.stale);
  EXPECT_EQ(status.reconnects, 1);
  EXPECT_EQ(source.describe(), "camera #2");

  // After a success the wait starts again from `initial`.
  camera.current->fail_next = true;
  EXPECT_EQ(source.next(0.0).status, FrameStatus::NotYet);
  EXPECT_DOUBLE_EQ(source.status().next_attempt_in_s, 0.5);
}

TEST(ReconnectingSource, NeverWaitsLongerThanTheTimeout) {
  FakeTime time;
  Camera camera(&time);
  ReconnectingSource source(camera.opener(), backoff(2.0, 8.0), time.clock());
  camera.current->fail_next = true;
  camera.plugged = false;
  EXPECT_EQ(source.next(0.0).status, FrameStatus::NotYet);
  time.sleeps.clear();
  EXPECT_EQ(source.next(0.25).status, FrameStatus::NotYet);
  EXPECT_EQ(source.next(0.25).status, FrameStatus::NotYet);
  ASSERT_EQ(time.sleeps.size(), 2u);
  // (FrameSource::next takes the real time spent from the timeout: microseconds here.)
  EXPECT_NEAR(time.sleeps[0], 0.25, 1e-3);
  EXPECT_NEAR(time.sleeps[1], 0.25, 1e-3);
  EXPECT_LE(time.sleeps[0], 0.25);
  EXPECT_EQ(camera.attempts.size(), 1u) << "no attempt before the backoff has passed";
  EXPECT_NEAR(source.status().next_attempt_in_s, 1.5, 2e-3);
}

TEST(ReconnectingSource, StaleWhenNoFrameComesForAWhile) {
  FakeTime time;
  Camera camera(&time);
  ReconnectingSource source(camera.opener(), backoff(0.5, 4.0), time.clock());
  camera.current->script = {ready(grey(4, 4, 1))};
  ASSERT_EQ(source.next(0).status, FrameStatus::Ready);
  time.advance(1.9);
  EXPECT_FALSE(source.status().stale);
  time.advance(0.2);
  EXPECT_TRUE(source.status().stale);
  EXPECT_TRUE(source.status().connected);
}

TEST(ReconnectingSource, ASilentSourceIsReopenedWhenSilenceIsSet) {
  FakeTime time;
  Camera camera(&time);
  BackoffSettings settings = backoff(0.5, 4.0);
  settings.silence_s = 5.0;
  ReconnectingSource source(camera.opener(), settings, time.clock());
  time.advance(4.0);
  EXPECT_EQ(source.next(0).status, FrameStatus::NotYet);
  EXPECT_TRUE(source.status().connected);
  time.advance(1.5);
  EXPECT_EQ(source.next(0).status, FrameStatus::NotYet);
  EXPECT_FALSE(source.status().connected);
  EXPECT_NE(source.status().last_error.find("no frame for"), std::string::npos);
  EXPECT_EQ(source.next(1.0).status, FrameStatus::NotYet);
  EXPECT_EQ(source.status().reconnects, 1);
}

TEST(ReconnectingSource, KeepsExposureAndCountsAcrossReopening) {
  FakeTime time;
  Camera camera(&time);
  ReconnectingSource source(camera.opener(), backoff(0.5, 4.0), time.clock());
  EXPECT_TRUE(source.set_exposure_time(0.004));
  camera.current->script = {ready(cv::Mat()), ready(grey(4, 4, 1))};
  ASSERT_EQ(source.next(1.0).status, FrameStatus::Ready);
  camera.current->fail_next = true;
  EXPECT_EQ(source.next(0).status, FrameStatus::NotYet);
  EXPECT_EQ(source.next(1.0).status, FrameStatus::NotYet);  // reopened
  ASSERT_EQ(camera.opened, 2);
  ASSERT_TRUE(camera.current->exposure_time.has_value());
  EXPECT_DOUBLE_EQ(*camera.current->exposure_time, 0.004);
  // The camera came back at another size: the sky table was built for the first one.
  camera.current->script = {ready(cv::Mat()), ready(grey(8, 8, 1))};
  EXPECT_EQ(source.next(1.0).status, FrameStatus::NotYet);
  const FrameCounts counts = source.counts();
  EXPECT_EQ(counts.delivered, 1);
  EXPECT_EQ(counts.dropped_empty, 2);  // one from each camera
  EXPECT_EQ(counts.dropped_size, 1);   // the new camera's 8 × 8 frame, refused by the wrapper
}

TEST(ReconnectingSource, TheFirstOpeningsErrorsPropagate) {
  FakeTime time;
  const auto absent = []() -> std::unique_ptr<FrameSource> { throw skylit::InputError("no camera 'x'"); };
  EXPECT_THROW(ReconnectingSource(absent, backoff(0.5, 4.0), time.clock()), skylit::InputError);
  Camera camera(&time);
  EXPECT_THROW(ReconnectingSource(camera.opener(), backoff(0.5, 0.1), time.clock()), skylit::InputError);
  EXPECT_THROW(ReconnectingSource(camera.opener(), backoff(0.0, 1.0), time.clock()), skylit::InputError);
}

TEST(RealtimeSource, HandsFramesOutAtTheirRecordedPace) {
  FakeTime time;
  auto scripted = std::make_unique<ScriptedSource>();
  scripted->script = {ready(grey(2, 2, 1), 10.0), ready(grey(2, 2, 2), 10.5), ready(grey(2, 2, 3), 11.0),
                      ready(grey(2, 2, 4), 0.0)};
  RealtimeSource source(std::move(scripted), 1.0, time.clock());
  ASSERT_EQ(source.next(5).status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(time.now, 0.0);
  ASSERT_EQ(source.next(5).status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(time.now, 0.5);
  EXPECT_EQ(source.next(0.1).status, FrameStatus::NotYet);  // due at 1.0
  EXPECT_NEAR(time.now, 0.6, 1e-3);
  FrameResult third = source.next(1.0);
  ASSERT_EQ(third.status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(third.frame.timestamp, 11.0);
  EXPECT_DOUBLE_EQ(time.now, 1.0);
  // A timestamp that goes back (a loop) is handed out at once and anchors again.
  ASSERT_EQ(source.next(0).status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(time.now, 1.0);
  EXPECT_EQ(source.counts().delivered, 4);
}

TEST(RealtimeSource, SpeedScalesThePace) {
  FakeTime time;
  auto scripted = std::make_unique<ScriptedSource>();
  scripted->script = {ready(grey(2, 2, 1), 0.0), ready(grey(2, 2, 2), 600.0)};
  RealtimeSource source(std::move(scripted), 60.0, time.clock());
  ASSERT_EQ(source.next(5).status, FrameStatus::Ready);
  ASSERT_EQ(source.next(20).status, FrameStatus::Ready);
  EXPECT_DOUBLE_EQ(time.now, 10.0);
  EXPECT_THROW(RealtimeSource(std::make_unique<ScriptedSource>(), 0.0, time.clock()), skylit::InputError);
}

}  // namespace
