// BlendWorkers: threads that poll briefly and then sleep, kept off the caller's CPU; a task
// counter; and a call that closes itself so that late risers find nothing to do.
#include "skylit/blend/workers.hpp"

#include <algorithm>
#include <chrono>

#if defined(__linux__)
#include <pthread.h>
#include <sched.h>
#endif

namespace skylit::blend {
namespace {

// How long a pool thread polls for the next call before it sleeps: longer than the gap between
// the plane blends of one sky, short enough to cost nothing worth measuring between skies.
constexpr std::chrono::microseconds kPollForNextCall{250};
// How long the caller polls for the pool threads' last tasks before it sleeps: a task is a chunk
// of texels (tens of µs for 40 faces, about 1 ms for 640), so this is usually enough.
constexpr std::chrono::microseconds kPollForLastTasks{2000};

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
  asm volatile("yield" ::: "memory");
#endif
}

// Polls `done` for up to `limit`; returns its last value.
template <class Done>
bool poll(const Done& done, std::chrono::microseconds limit) {
  const auto until = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    for (int i = 0; i < 32; ++i) {
      cpu_relax();
      if (done()) return true;
    }
    if (std::chrono::steady_clock::now() >= until) return done();
  }
  return true;
}

}  // namespace

BlendWorkers::BlendWorkers(int threads) {
#if defined(__linux__)
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (pthread_getaffinity_np(pthread_self(), sizeof allowed, &allowed) == 0) {
    for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu) {
      if (CPU_ISSET(cpu, &allowed)) allowed_cpus_.push_back(cpu);
    }
  }
#endif
  const int total = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads_.reserve(static_cast<std::size_t>(total - 1));
  for (int w = 1; w < total; ++w) threads_.emplace_back([this, w] { serve(w); });
}

BlendWorkers::~BlendWorkers() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
    posted_.store(++generation_, std::memory_order_release);  // ends any polling
  }
  wake_.notify_all();
  threads_.clear();  // joins
}

void BlendWorkers::work(const std::function<void(std::size_t, int)>& task, std::size_t tasks, int worker) {
  for (std::size_t i = next_++; i < tasks; i = next_++) task(i, worker);
}

void BlendWorkers::serve(int worker) {
  std::uint64_t seen = 0;
  while (true) {
    poll([&] { return posted_.load(std::memory_order_acquire) != seen; }, kPollForNextCall);
    std::unique_lock lock(mutex_);
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    if (!task_) continue;  // woke after the call closed: nothing left, nothing to hold up
    const auto* task = task_;  // valid until busy_ is back to 0
    const std::size_t tasks = tasks_;
    busy_.fetch_add(1, std::memory_order_relaxed);
    lock.unlock();
    work(*task, tasks, worker);
    lock.lock();
    // Release: the caller may see 0 by polling, without the mutex, and then read the results.
    if (busy_.fetch_sub(1, std::memory_order_release) == 1) idle_.notify_all();
  }
}

void BlendWorkers::keep_off_caller_cpu() {
#if defined(__linux__)
  if (threads_.empty() || allowed_cpus_.size() < 2) return;
  const int cpu = sched_getcpu();
  if (cpu < 0 || cpu == steered_from_) return;
  steered_from_ = cpu;
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  for (const int c : allowed_cpus_) {
    if (c != cpu) CPU_SET(c, &allowed);
  }
  // A failure (a thread bound elsewhere by a policy of the process's owner) leaves that thread
  // where it was: the blend is still correct.
  for (std::jthread& t : threads_) pthread_setaffinity_np(t.native_handle(), sizeof allowed, &allowed);
#endif
}

void BlendWorkers::run(std::size_t tasks, const std::function<void(std::size_t, int)>& task) {
  const std::lock_guard turn(turn_);
  keep_off_caller_cpu();
  {
    const std::lock_guard lock(mutex_);
    task_ = &task;
    tasks_ = tasks;
    next_ = 0;
    posted_.store(++generation_, std::memory_order_release);
  }
  if (!threads_.empty() && tasks > 1) wake_.notify_all();
  work(task, tasks, 0);
  // Every task is taken; close the call and wait only for threads still finishing theirs.
  {
    const std::lock_guard lock(mutex_);
    task_ = nullptr;
  }
  if (poll([&] { return busy_.load(std::memory_order_acquire) == 0; }, kPollForLastTasks)) return;
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [&] { return busy_.load(std::memory_order_acquire) == 0; });
}

}  // namespace skylit::blend
