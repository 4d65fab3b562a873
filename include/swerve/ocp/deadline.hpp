// The time every real-time part of SwerveMPC reads, and the deadline a solve must meet. Time comes
// from a Clock, the steady clock by default; tests inject a clock that advances by the work done
// (per model evaluation), so deadline logic is tested deterministically rather than by wall time.
#pragma once

#include <atomic>
#include <chrono>
#include <cmath>

namespace swerve {

using SolverClock = std::chrono::steady_clock;
using TimePoint = SolverClock::time_point;
using Duration = SolverClock::duration;

class Clock {
 public:
  virtual ~Clock() = default;
  virtual TimePoint now() const noexcept = 0;
  // Work done by a model on this clock's behalf, in module evaluations (one swerve module's forces
  // and wear, in double). The wall clock ignores it: the time it took is already on the clock.
  virtual void charge(double module_evaluations) const noexcept { (void)module_evaluations; }
};

// The process's steady clock (the default everywhere). A namespace-scope object: no
// function-local static on the real-time path.
const Clock& steady_clock() noexcept;

inline Duration to_duration(double seconds) noexcept {
  return std::chrono::duration_cast<Duration>(std::chrono::duration<double>(seconds));
}
inline double to_seconds(Duration duration) noexcept { return std::chrono::duration<double>(duration).count(); }
// A backend's estimate of a recurring duration (an iteration, a startup) after a new measurement:
// it rises at once and falls halfway, so a slower run is believed and a faster one averaged.
inline Duration updated_estimate(Duration estimate, Duration measured) noexcept {
  return measured > estimate ? measured : (measured + estimate) / 2;
}

// A clock that advances by the work done rather than the time taken: `per_read` at every read
// (the solvers read once per proposal or iteration, the controller a few times per step), plus
// `per_module_evaluation` for every module evaluation a prediction model charges (charge()), plus
// whatever advance() adds. The model's charge makes a proposal cost in proportion to the modules
// and substeps it evaluates, as on the wall clock; reads alone price a 10-module vehicle's
// proposal like a 2-module one's. A run on it does the same work on every machine, under any load and under an
// emulator, so it is repeatable bit for bit and its instructions can be counted (`swerve-mpc run
// --work-clock`, scripts/cpu_slowdown.py); deadline tests use it too. Reads, charges and advances
// are atomic, so a solver's worker threads may share one (their interleaving then decides which
// read sees which time, so a multi-threaded run is safe but not bit-repeatable).
class WorkClock final : public Clock {
 public:
  explicit WorkClock(double per_read_s = 0.0, double per_module_evaluation_s = 0.0) noexcept
      : per_read_(to_duration(per_read_s).count()),
        per_module_evaluation_(std::chrono::duration<double, Duration::period>(
                                   std::chrono::duration<double>(per_module_evaluation_s))
                                   .count()) {}
  WorkClock(const WorkClock& other) noexcept
      : per_read_(other.per_read_),
        per_module_evaluation_(other.per_module_evaluation_),
        ticks_(other.ticks_.load()),
        reads_(other.reads_.load()) {}
  WorkClock& operator=(const WorkClock&) = delete;
  TimePoint now() const noexcept override {
    reads_.fetch_add(1, std::memory_order_relaxed);
    return TimePoint(Duration(ticks_.fetch_add(per_read_, std::memory_order_relaxed) + per_read_));
  }
  void charge(double module_evaluations) const noexcept override {
    if (!(module_evaluations > 0.0) || per_module_evaluation_ == 0.0) return;
    ticks_.fetch_add(static_cast<Duration::rep>(std::llround(module_evaluations * per_module_evaluation_)),
                     std::memory_order_relaxed);
  }
  void advance(Duration by) noexcept { ticks_.fetch_add(by.count(), std::memory_order_relaxed); }
  long reads() const noexcept { return reads_.load(std::memory_order_relaxed); }

 private:
  Duration::rep per_read_;
  double per_module_evaluation_;  // in the clock's ticks
  mutable std::atomic<Duration::rep> ticks_{0};
  mutable std::atomic<long> reads_{0};
};

// A point in time on a given clock. Built implicitly from a steady-clock time point, so
// `SolverClock::now() + 20ms` still reads as a deadline; `Deadline(at, clock)` names another clock.
class Deadline {
 public:
  Deadline() noexcept : Deadline(TimePoint{}) {}  // long past, on the steady clock
  Deadline(TimePoint at, const Clock& clock = steady_clock()) noexcept : at_(at), clock_(&clock) {}  // NOLINT

  // `budget` from now on `clock`.
  static Deadline in(Duration budget, const Clock& clock = steady_clock()) noexcept {
    return Deadline(clock.now() + budget, clock);
  }

  TimePoint at() const noexcept { return at_; }
  const Clock& clock() const noexcept { return *clock_; }
  TimePoint now() const noexcept { return clock_->now(); }
  Duration remaining() const noexcept { return at_ - clock_->now(); }
  bool passed() const noexcept { return clock_->now() >= at_; }
  // Whether this is the process's steady clock (a library's own wall-time limit then agrees with it).
  bool on_steady_clock() const noexcept { return clock_ == &steady_clock(); }
  // The same clock, `margin` earlier (a backend keeping slack for its final evaluation).
  Deadline earlier_by(Duration margin) const noexcept { return Deadline(at_ - margin, *clock_); }

 private:
  TimePoint at_;
  const Clock* clock_;
};

}  // namespace swerve
