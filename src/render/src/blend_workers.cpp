// BlendWorkers: sleeping threads, a task counter, and a call that closes itself so that late
// risers find nothing to do.
#include "skylit/render/blend_workers.hpp"

#include <algorithm>

namespace skylit::render {

BlendWorkers::BlendWorkers(int threads) {
  const int total = threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads_.reserve(static_cast<std::size_t>(total - 1));
  for (int w = 1; w < total; ++w) threads_.emplace_back([this, w] { serve(w); });
}

BlendWorkers::~BlendWorkers() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  threads_.clear();  // joins
}

void BlendWorkers::work(const std::function<void(std::size_t, int)>& task, std::size_t tasks, int worker) {
  for (std::size_t i = next_++; i < tasks; i = next_++) task(i, worker);
}

void BlendWorkers::serve(int worker) {
  std::uint64_t seen = 0;
  std::unique_lock lock(mutex_);
  while (true) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    if (!task_) continue;  // woke after the call closed: nothing left, nothing to hold up
    const auto* task = task_;  // valid until busy_ is back to 0
    const std::size_t tasks = tasks_;
    ++busy_;
    lock.unlock();
    work(*task, tasks, worker);
    lock.lock();
    if (--busy_ == 0) idle_.notify_all();
  }
}

void BlendWorkers::run(std::size_t tasks, const std::function<void(std::size_t, int)>& task) {
  const std::lock_guard turn(turn_);
  {
    const std::lock_guard lock(mutex_);
    task_ = &task;
    tasks_ = tasks;
    next_ = 0;
    ++generation_;
  }
  if (!threads_.empty() && tasks > 1) wake_.notify_all();
  work(task, tasks, 0);
  // Every task is taken; close the call and wait only for threads still finishing theirs.
  std::unique_lock lock(mutex_);
  task_ = nullptr;
  idle_.wait(lock, [&] { return busy_ == 0; });
}

}  // namespace skylit::render
