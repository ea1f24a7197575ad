// Hours of running in a few seconds: a tiny camera looping over its recording as fast as the
// renderer takes it (mailboxes, not queues: a slow stage drops frames instead of piling them up).
// Resident memory is allowed to settle while the first lit frames fill the GL driver's caches
// (shader variants, buffer pools: a few MiB, bounded); over the frames after that it must stay flat.
// A leak of 200 bytes a frame would show: the test fails on it.
#include <chrono>
#include <cstdio>

#include <gtest/gtest.h>

#include "live_fixture.hpp"

namespace skylit::live_test {
namespace {

TEST(ServiceSoak, TenThousandFramesKeepMemoryFlat) {
  // Counted in frames drawn with a sky (the frames before the first sky show the camera alone).
  constexpr std::int64_t kSettle = 4000, kFlat = 10000;
  RigOptions rig_options;
  rig_options.hmd_width = 24;  // tiny: the test is about memory, not pixels
  rig_options.hmd_height = 18;
  rig_options.camera_frames = 4;
  rig_options.camera_realtime = "";  // as fast as the renderer takes them
  const Rig rig(rig_options);
  live::ServiceOptions options = quiet_options();
  // The frames without a sky come first, as many as the sky stage takes to start; the run is
  // stopped once the lit frames are counted (the cap only guards against a sky that never comes).
  options.frames = kSettle + kFlat + 100000;

  const auto start = std::chrono::steady_clock::now();
  RunningService running(rig.config(), options);
  // RSS once the lit frames have settled, the largest RSS from then until kFlat lit frames later,
  // and the RSS at that point (the service's GL context and threads are gone once run() returns).
  std::int64_t rss_settled = 0, rss_max = 0, rss_late = 0, lit_late = 0;
  double settled_time = 0, late_time = 0;
  while (!running.done()) {
    const nlohmann::json status = running.status();
    const std::int64_t lit = status["frames"].get<std::int64_t>() - status["frames_without_sky"].get<std::int64_t>();
    const std::int64_t rss = resident_bytes();
    const double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (lit >= kSettle && rss_settled == 0) {
      rss_settled = rss;
      settled_time = now;
    }
    if (rss_settled > 0 && lit <= kSettle + kFlat) {
      rss_max = std::max(rss_max, rss);
      rss_late = rss;
      lit_late = lit;
      late_time = now;
    }
    if (lit > kSettle + kFlat) running.service().stop();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::int64_t done = running.join();
  ASSERT_TRUE(running.error().empty()) << running.error();
  ASSERT_LT(done, *options.frames) << "the sky never arrived";
  ASSERT_GT(rss_settled, 0) << "the service never drew " << kSettle << " frames with a sky";
  const nlohmann::json status = running.status();
  constexpr double kMiB = 1024.0 * 1024.0;
  const std::int64_t measured = lit_late - kSettle;
  std::printf("measured: %lld frames of 24×18 (%lld without a sky; %lld camera frames replaced unseen); RSS %.1f MiB "
              "after %lld lit frames (%.1f s), %.1f MiB %lld frames later (%.2f ms a frame), at most %.1f MiB in "
              "between: %.0f bytes a frame\n",
              static_cast<long long>(done), static_cast<long long>(status["frames_without_sky"].get<std::int64_t>()),
              static_cast<long long>(status["dropped_frames"].get<std::int64_t>()), rss_settled / kMiB,
              static_cast<long long>(kSettle), settled_time, rss_late / kMiB, static_cast<long long>(measured),
              measured > 0 ? 1e3 * (late_time - settled_time) / static_cast<double>(measured) : 0.0, rss_max / kMiB,
              measured > 0 ? static_cast<double>(rss_late - rss_settled) / static_cast<double>(measured) : 0.0);
  EXPECT_GT(measured, kFlat - 1000);
  EXPECT_LT(rss_late - rss_settled, static_cast<std::int64_t>(2 * kMiB));
  EXPECT_LT(rss_max - rss_settled, static_cast<std::int64_t>(2 * kMiB));
}

}  // namespace
}  // namespace skylit::live_test
