// BlendWorkers: every task runs exactly once per call, on a worker index within the pool, call
// after call; calls from several threads take turns; a pool of one runs on the caller; a pool
// destroyed while its threads poll for the next call ends; on Linux the pool threads are kept
// off the caller's CPU.
#include <atomic>
#include <thread>
#include <vector>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

#include <gtest/gtest.h>

#include "skylit/blend/workers.hpp"

namespace skylit::blend {
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

TEST(BlendWorkers, DestroyedRightAfterACallEnds) {
  // The pool threads are still polling for the next call when the destructor runs: it must end
  // their polling and join them (a hang here fails the test by its time limit).
  for (int round = 0; round < 50; ++round) {
    BlendWorkers workers(3);
    std::atomic<int> count{0};
    workers.run(16, [&](std::size_t, int) { count.fetch_add(1); });
    ASSERT_EQ(count.load(), 16);
  }
}

#if defined(__linux__)

// Restores the calling thread's affinity, whatever the test does to it.
class AffinityGuard {
 public:
  AffinityGuard() {
    CPU_ZERO(&saved_);
    ok_ = pthread_getaffinity_np(pthread_self(), sizeof saved_, &saved_) == 0;
  }
  ~AffinityGuard() {
    if (ok_) pthread_setaffinity_np(pthread_self(), sizeof saved_, &saved_);
  }
  AffinityGuard(const AffinityGuard&) = delete;
  AffinityGuard& operator=(const AffinityGuard&) = delete;
  bool ok() const { return ok_; }
  const cpu_set_t& saved() const { return saved_; }

 private:
  cpu_set_t saved_;
  bool ok_ = false;
};

TEST(BlendWorkers, KeepsPoolThreadsOffTheCallersCpu) {
  const AffinityGuard guard;
  ASSERT_TRUE(guard.ok());
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c) {
    if (CPU_ISSET(c, &guard.saved())) cpus.push_back(c);
  }
  if (cpus.size() < 2) GTEST_SKIP() << "this process may run on one CPU only";

  constexpr int kWorkers = 3;
  BlendWorkers workers(kWorkers);
  // The caller moves from one CPU to another and back; each call must steer the pool threads.
  for (const int caller_cpu : {cpus[0], cpus[1], cpus[0]}) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(caller_cpu, &one);
    ASSERT_EQ(pthread_setaffinity_np(pthread_self(), sizeof one, &one), 0);
    struct Mask {
      cpu_set_t set;
    };
    std::vector<Mask> masks(kWorkers);
    std::atomic<int> arrived{0};
    // Each task waits until every worker holds one, so that every pool thread reports.
    workers.run(kWorkers, [&](std::size_t, int worker) {
      CPU_ZERO(&masks[static_cast<std::size_t>(worker)].set);
      pthread_getaffinity_np(pthread_self(), sizeof(cpu_set_t), &masks[static_cast<std::size_t>(worker)].set);
      arrived.fetch_add(1);
      while (arrived.load() < kWorkers) std::this_thread::yield();
    });
    for (int w = 1; w < kWorkers; ++w) {
      const cpu_set_t& m = masks[static_cast<std::size_t>(w)].set;
      EXPECT_FALSE(CPU_ISSET(caller_cpu, &m)) << "pool thread " << w << " may run on the caller's CPU " << caller_cpu;
      EXPECT_GT(CPU_COUNT(&m), 0) << "pool thread " << w;
      for (int c = 0; c < CPU_SETSIZE; ++c) {
        if (CPU_ISSET(c, &m)) {
          EXPECT_TRUE(CPU_ISSET(c, &guard.saved())) << "CPU " << c << " was not allowed";
        }
      }
    }
  }
}

#endif

}  // namespace
}  // namespace skylit::blend
