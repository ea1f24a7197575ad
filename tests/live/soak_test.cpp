// Hours of running in a few seconds: 10⁴ frames of a tiny camera looping over its recording, the
// resident memory after them against that after the first 1000 (mailboxes, not queues: a slow
// stage drops frames instead of piling them up).
#include <chrono>
#include <cstdio>

#include <gtest/gtest.h>

#include "live_fixture.hpp"

namespace skylit::live_test {
namespace {

TEST(ServiceSoak, TenThousandFramesKeepMemoryFlat) {
  constexpr std::int64_t kFrames = 10000, kWarmUp = 1000;
  RigOptions rig_options;
  rig_options.hmd_width = 24;  // tiny: the test is about memory, not pixels
  rig_options.hmd_height = 18;
  rig_options.camera_frames = 4;
  rig_options.camera_realtime = "";  // as fast as the renderer takes them
  const Rig rig(rig_options);
  live::ServiceOptions options = quiet_options();
  options.frames = kFrames;

  const auto start = std::chrono::steady_clock::now();
  RunningService running(rig.config(), options);
  // RSS after the warm-up, and the largest RSS seen from then until just before the end (the
  // service's GL context and threads are gone once run() returns).
  std::int64_t rss_warm = 0, rss_max = 0, rss_late = 0, frames_late = 0;
  double warm_time = 0;
  while (!running.done()) {
    const std::int64_t frames = running.status()["frames"].get<std::int64_t>();
    const std::int64_t rss = resident_bytes();
    if (frames >= kWarmUp && rss_warm == 0) {
      rss_warm = rss;
      warm_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    if (rss_warm > 0) rss_max = std::max(rss_max, rss);
    if (frames < kFrames) {
      rss_late = rss;
      frames_late = frames;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::int64_t done = running.join();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(running.error().empty()) << running.error();
  ASSERT_EQ(done, kFrames);
  ASSERT_GT(rss_warm, 0);
  const nlohmann::json status = running.status();
  constexpr double kMiB = 1024.0 * 1024.0;
  std::printf("measured: %lld frames of 24×18 in %.1f s (%.2f ms a frame; %lld camera frames replaced unseen); RSS "
              "%.1f MiB after %lld frames (%.1f s), %.1f MiB at frame %lld, at most %.1f MiB in between\n",
              static_cast<long long>(done), seconds, 1e3 * (seconds - warm_time) / static_cast<double>(kFrames - kWarmUp),
              static_cast<long long>(status["dropped_frames"].get<std::int64_t>()), rss_warm / kMiB,
              static_cast<long long>(kWarmUp), warm_time, rss_late / kMiB, static_cast<long long>(frames_late),
              rss_max / kMiB);
  EXPECT_GT(frames_late, kFrames - 500);
  EXPECT_LT(rss_late - rss_warm, static_cast<std::int64_t>(4 * kMiB));
  EXPECT_LT(rss_max - rss_warm, static_cast<std::int64_t>(4 * kMiB));
}

}  // namespace
}  // namespace skylit::live_test
