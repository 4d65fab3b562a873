#include "worker_pool.hpp"

#include <utility>

namespace swerve {

WorkerPool::WorkerPool(int count, std::function<void(std::size_t)> job) : job_(std::move(job)) {
  threads_.reserve(static_cast<std::size_t>(count));
  try {
    for (int w = 0; w < count; ++w) threads_.emplace_back([this, w] { loop(static_cast<std::size_t>(w)); });
  } catch (...) {  // a thread the system refused: stop those already started, then report
    stop_and_join();
    throw;
  }
}

WorkerPool::~WorkerPool() { stop_and_join(); }

void WorkerPool::start() noexcept {
  finished_.store(0, std::memory_order_relaxed);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
}

void WorkerPool::wait() const noexcept {
  while (finished_.load(std::memory_order_acquire) < threads_.size()) std::this_thread::yield();
}

void WorkerPool::begin_solve() noexcept {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    solving_.store(true, std::memory_order_release);
  }
  wake_.notify_all();
}

void WorkerPool::end_solve() noexcept { solving_.store(false, std::memory_order_release); }

void WorkerPool::stop_and_join() noexcept {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_release);
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void WorkerPool::loop(std::size_t index) {
  unsigned long seen = 0;
  for (;;) {
    int spins = 0;
    unsigned long generation = generation_.load(std::memory_order_acquire);
    while (generation == seen && !stop_.load(std::memory_order_acquire)) {
      if (solving_.load(std::memory_order_acquire) || ++spins < kSpinYields) {
        std::this_thread::yield();
      } else {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] {
          return generation_.load(std::memory_order_acquire) != seen || stop_.load(std::memory_order_acquire) ||
                 solving_.load(std::memory_order_acquire);
        });
        spins = 0;
      }
      generation = generation_.load(std::memory_order_acquire);
    }
    if (stop_.load(std::memory_order_acquire)) return;
    seen = generation;
    job_(index);
    finished_.fetch_add(1, std::memory_order_acq_rel);
  }
}

WorkerPool::Solving::Solving(WorkerPool* pool) noexcept : pool_(pool) {
  if (pool_ != nullptr) pool_->begin_solve();
}

WorkerPool::Solving::~Solving() {
  if (pool_ != nullptr) pool_->end_solve();
}

}  // namespace swerve
