#pragma once
// A small pool of threads kept between blends (BlendOptions::workers), so that a blend's tasks
// go to threads already running instead of threads made for every call.
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace skylit::blend {

// Creating threads for every call costs little on an idle machine, but on a busy one a fresh
// thread may wait a whole scheduler slice before it runs, and the call must wait for it to start
// and end. A call hands out tasks through a counter, the caller works too, and a thread that
// wakes after every task is taken does nothing and holds nothing up.
//
// Two things decide whether a second thread helps at all (measured on a 2-vCPU virtual machine,
// where a 2-thread blend ran no faster than 1 thread before them):
// - Where a woken thread runs. Linux may wake a sleeping thread on the CPU of the thread that
//   woke it (a guest kernel that sees no shared cache between its CPUs does so every time); the
//   two then take turns on one CPU. On Linux the pool threads are kept off the caller's CPU:
//   their affinity is the CPUs the pool was created with (its creator's affinity) minus the one
//   the caller runs on, updated when a call comes from another CPU.
// - How long a wake takes. Waking a thread on an idle CPU took 0.05–0.15 ms (median) and up to
//   several ms on that machine, against ~1 ms for a 40-face plane. So the threads poll for the
//   next call for a short while after each one, and the caller polls for the threads' last
//   tasks before it sleeps: back-to-back calls (the planes of one sky) never wait for a wake.
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
  void keep_off_caller_cpu();

  std::mutex turn_;                     // one run() at a time
  std::mutex mutex_;                    // guards everything below but the atomics
  std::condition_variable wake_;
  std::condition_variable idle_;
  const std::function<void(std::size_t, int)>* task_ = nullptr;  // null: no call open
  std::size_t tasks_ = 0;
  std::uint64_t generation_ = 0;
  std::atomic<std::uint64_t> posted_{0};  // generation_, for threads polling without the lock
  std::atomic<int> busy_{0};            // pool threads inside the current call (changed under mutex_)
  bool stop_ = false;
  std::atomic<std::size_t> next_{0};
  std::vector<int> allowed_cpus_;       // the creator's affinity (Linux; empty elsewhere)
  int steered_from_ = -1;               // the CPU the threads were last kept off (guarded by turn_)
  std::vector<std::jthread> threads_;
};

}  // namespace skylit::blend
