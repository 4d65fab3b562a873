// A fixed set of worker threads that each run their part of the job in flight, for the annealer's
// batched proposals and its polish's gradient shares. Between jobs of a solve a worker spins
// (yielding) for the next one; outside a solve, after ~kSpinYields idle yields, it sleeps on a
// condition variable, so an idle solver costs no core. Nothing allocates after construction.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace swerve {

class WorkerPool {
 public:
  // Starts `count` threads; worker w runs job(w) once per start(). Throws std::system_error when the
  // system refuses a thread (those already started are stopped first).
  WorkerPool(int count, std::function<void(std::size_t)> job);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Every worker runs its part of the job once; wait() returns when all have.
  void start() noexcept;
  void wait() const noexcept;

  // While one lives the workers never sleep: woken at a solve's start, they are spinning by its
  // first job, while the calling thread does the solve's serial start.
  class Solving {
   public:
    explicit Solving(WorkerPool* pool) noexcept;  // nullptr: no pool, nothing to do
    ~Solving();
    Solving(const Solving&) = delete;
    Solving& operator=(const Solving&) = delete;

   private:
    WorkerPool* pool_;
  };

 private:
  static constexpr int kSpinYields = 20000;  // ~ms of idle yields outside a solve before sleeping

  void begin_solve() noexcept;
  void end_solve() noexcept;
  void stop_and_join() noexcept;
  void loop(std::size_t index);

  std::function<void(std::size_t)> job_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::atomic<unsigned long> generation_{0};
  std::atomic<std::size_t> finished_{0};
  std::atomic<bool> stop_{false};
  std::atomic<bool> solving_{false};
};

}  // namespace swerve
