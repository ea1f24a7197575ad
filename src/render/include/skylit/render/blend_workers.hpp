#pragma once
// A small pool of threads kept between blends (BlendOptions::workers). Creating threads for
// every call costs little on an idle machine, but on a busy one a fresh thread may wait a whole
// scheduler slice before it runs, and the call must wait for it to start and end. The pool's
// threads sleep between calls; a call hands out tasks through a counter, the caller works too,
// and a thread that wakes after every task is taken does nothing and holds nothing up.
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace skylit::render {

class BlendWorkers {
 public:
  // `threads` workers in all, the caller included (0 = all hardware threads).
  explicit BlendWorkers(int threads = 0);
  ~BlendWorkers();  // wakes and joins the threads
  BlendWorkers(const BlendWorkers&) = delete;
  BlendWorkers& operator=(const BlendWorkers&) = delete;

  int size() const { return static_cast<int>(threads_.size()) + 1; }

  // Calls task(i, worker) for every i in [0, tasks), each once, worker in [0, size()) (0 = the
  // calling thread), and returns when all are done. Calls from several threads take turns.
  // `task` must not throw.
  void run(std::size_t tasks, const std::function<void(std::size_t task, int worker)>& task);

 private:
  void work(const std::function<void(std::size_t, int)>& task, std::size_t tasks, int worker);
  void serve(int worker);

  std::mutex turn_;                     // one run() at a time
  std::mutex mutex_;                    // guards everything below but next_
  std::condition_variable wake_;
  std::condition_variable idle_;
  const std::function<void(std::size_t, int)>* task_ = nullptr;  // null: no call open
  std::size_t tasks_ = 0;
  std::uint64_t generation_ = 0;
  int busy_ = 0;                        // pool threads inside the current call
  bool stop_ = false;
  std::atomic<std::size_t> next_{0};
  std::vector<std::jthread> threads_;
};

}  // namespace skylit::render
