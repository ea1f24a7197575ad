#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include "skylit/live/frame_stats.hpp"
#include "skylit/live/mailbox.hpp"

namespace skylit::live {
namespace {

using namespace std::chrono_literals;

TEST(Mailbox, KeepsOnlyTheNewestAndCountsWhatWasOverwritten) {
  Mailbox<int> box;
  EXPECT_FALSE(box.try_take());
  box.put(1);
  box.put(2);
  box.put(3);
  EXPECT_EQ(box.overwritten(), 2u);
  EXPECT_EQ(box.version(), 3u);
  EXPECT_EQ(box.try_take(), 3);
  EXPECT_FALSE(box.try_take());
}

TEST(Mailbox, TakeWaitsForAWriterAndCloseWakesIt) {
  Mailbox<std::string> box;
  std::thread writer([&] {
    std::this_thread::sleep_for(20ms);
    box.put("sky");
  });
  EXPECT_EQ(box.take(5s), "sky");
  writer.join();
  EXPECT_FALSE(box.take(1ms));  // timeout, nothing there

  std::thread closer([&] {
    std::this_thread::sleep_for(20ms);
    box.close();
  });
  const auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(box.take(30s));
  EXPECT_LT(std::chrono::steady_clock::now() - start, 10s);  // woken by close, not the timeout
  closer.join();
  box.put("late");
  EXPECT_FALSE(box.try_take());
}

TEST(Mailbox, AFastWriterAndASlowReaderLoseValuesNotMemory) {
  // Nothing queues up: every value put is either taken or counted as overwritten, values only
  // move forward, and the last one put is the last one taken.
  Mailbox<std::vector<int>> box;
  std::atomic<bool> done = false;
  std::thread writer([&] {
    for (int i = 0; i < 20000; ++i) box.put(std::vector<int>(64, i));
    done = true;
  });
  int last = -1;
  std::uint64_t taken = 0;
  const auto take_one = [&](std::optional<std::vector<int>> v) {
    if (!v) return;
    EXPECT_GT(v->front(), last);
    last = v->front();
    ++taken;
  };
  while (!done) take_one(box.take(1ms));
  writer.join();
  take_one(box.try_take());
  EXPECT_EQ(last, 19999);
  EXPECT_EQ(box.overwritten() + taken, 20000u);
}

TEST(FrameTimes, PercentilesAndRateOverTheWindow) {
  FrameTimes times(100);
  EXPECT_EQ(times.percentile(0.5), 0.0);
  EXPECT_EQ(times.rate(), 0.0);
  // 1..200 ms, one frame every 1/30 s: the window keeps the last 100 (101..200 ms).
  for (int i = 1; i <= 200; ++i) times.add(i / 1000.0, i / 30.0);
  EXPECT_EQ(times.count(), 100u);
  EXPECT_DOUBLE_EQ(times.percentile(0.5), 0.150);
  EXPECT_DOUBLE_EQ(times.percentile(0.99), 0.199);
  EXPECT_DOUBLE_EQ(times.percentile(1.0), 0.200);
  EXPECT_DOUBLE_EQ(times.percentile(0.0), 0.101);
  EXPECT_NEAR(times.rate(), 30.0, 1e-9);
}

}  // namespace
}  // namespace skylit::live
