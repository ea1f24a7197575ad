// BlendWorkers: every task runs exactly once per call, on a worker index within the pool, call
// after call; calls from several threads take turns; a pool of one runs on the caller.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "skylit/render/blend_workers.hpp"

namespace skylit::render {
namespace {

TEST(BlendWorkers, EveryTaskRunsOnceOnAValidWorker) {
  BlendWorkers workers(4);
  ASSERT_EQ(workers.size(), 4);
  for (const std::size_t tasks : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{1000}}) {
    for (int call = 0; call < 20; ++call) {
      std::vector<std::atomic<int>> runs(tasks);
      std::atomic<bool> bad_worker{false};
      workers.run(tasks, [&](std::size_t i, int worker) {
        runs[i].fetch_add(1);
        if (worker < 0 || worker >= workers.size()) bad_worker = true;
      });
      for (std::size_t i = 0; i < tasks; ++i) ASSERT_EQ(runs[i].load(), 1) << "task " << i << " of " << tasks;
      ASSERT_FALSE(bad_worker.load());
    }
  }
}

TEST(BlendWorkers, PoolOfOneRunsOnTheCaller) {
  BlendWorkers workers(1);
  EXPECT_EQ(workers.size(), 1);
  const std::thread::id caller = std::this_thread::get_id();
  int count = 0;
  workers.run(7, [&](std::size_t, int worker) {
    EXPECT_EQ(worker, 0);
    EXPECT_EQ(std::this_thread::get_id(), caller);
    ++count;  // one thread: no race
  });
  EXPECT_EQ(count, 7);
  EXPECT_GE(BlendWorkers().size(), 1);  // 0 = all hardware threads
}

TEST(BlendWorkers, CallsFromSeveralThreadsTakeTurns) {
  // Each call claims `owner` in its first task and frees it in its last: a task of another call
  // in between would find it taken.
  BlendWorkers workers(3);
  constexpr int kCallers = 4;
  constexpr int kCalls = 25;
  constexpr std::size_t kTasks = 64;
  std::atomic<int> owner{0};
  std::atomic<bool> overlapped{false};
  std::vector<std::atomic<std::size_t>> done(kCallers * kCalls + 1);
  {
    std::vector<std::jthread> callers;
    for (int c = 0; c < kCallers; ++c) {
      callers.emplace_back([&, c] {
        for (int call = 0; call < kCalls; ++call) {
          const int id = c * kCalls + call + 1;
          workers.run(kTasks, [&, id](std::size_t, int) {
            int expected = 0;
            if (!owner.compare_exchange_strong(expected, id) && expected != id) overlapped = true;
            if (done[static_cast<std::size_t>(id)].fetch_add(1) + 1 == kTasks) owner = 0;
          });
        }
      });
    }
  }
  for (std::size_t id = 1; id < done.size(); ++id) EXPECT_EQ(done[id].load(), kTasks) << id;
  EXPECT_FALSE(overlapped.load());
}

}  // namespace
}  // namespace skylit::render
