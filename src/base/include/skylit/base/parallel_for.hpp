#pragma once
// The modules' one parallel loop over a range of items, on threads started for the call. (The
// blend's persistent pool, blend/workers.hpp, is for the live service's per-frame work.)
#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace skylit {

// Runs work(item) for item in [0, count) on up to `threads` threads (0: one per hardware
// thread), the caller's among them. Items are handed out one at a time, so uneven items balance;
// each should write only its own output, so that the result does not depend on the schedule. The
// first exception thrown by any item stops the others taking new items and is rethrown here.
template <typename Work>
void parallel_for(int count, int threads, const Work& work) {
  if (count <= 0) return;
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::atomic<int> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&] {
    try {
      for (int item = next++; item < count; item = next++) work(item);
    } catch (...) {
      const std::lock_guard lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = count;
    }
  };
  const int used = std::min(threads, count);
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(used - 1));
  for (int t = 1; t < used; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace skylit
