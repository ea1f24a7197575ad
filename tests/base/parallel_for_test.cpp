#include "skylit/base/parallel_for.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace skylit {
namespace {

TEST(ParallelFor, RunsEveryItemOnce) {
  for (const int threads : {0, 1, 3, 64}) {
    std::vector<std::atomic<int>> runs(1000);
    parallel_for(1000, threads, [&](int item) { ++runs[static_cast<std::size_t>(item)]; });
    for (const std::atomic<int>& count : runs) EXPECT_EQ(count.load(), 1) << threads << " threads";
  }
  int calls = 0;
  parallel_for(0, 4, [&](int) { ++calls; });
  parallel_for(-3, 4, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ParallelFor, RethrowsAFailureAfterEveryThreadHasStopped) {
  std::atomic<int> running{0};
  try {
    parallel_for(1000, 4, [&](int item) {
      ++running;
      if (item == 10) {
        --running;
        throw std::runtime_error("item 10");
      }
      --running;
    });
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "item 10");
    EXPECT_EQ(running.load(), 0);  // joined before the rethrow
  }
}

}  // namespace
}  // namespace skylit
