// A solve budget counted in work rather than in time: the solve stops when the work it did, priced
// at a target's rates (per clock read, per module evaluation), reaches its share of the budget. The
// same inputs then get the same answer on every machine and in every run; the step's own clock
// stays the guard that ends the solve when the machine is slower than its rates say (after the
// proposal in flight, which short budgets cannot afford: docs/decisions/work-budget.md).
#pragma once

#include <atomic>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/deadline.hpp"
#include "swerve/ocp/work_clock_rates.hpp"

namespace swerve {

struct WorkBudgetOptions {
  bool enabled = false;  // false: the solve stops by the step's clock alone (the wall clock on a vehicle)
  // What a solver's clock read and a prediction model's module evaluation cost on the target (s).
  // The defaults are the reference machine's (work_clock_rates.hpp); a slower target scales both.
  double seconds_per_read = kReferenceSecondsPerRead;
  double seconds_per_module_evaluation = kReferenceSecondsPerModuleEvaluation;

  static const OptionFields<WorkBudgetOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;  // throws ConfigError naming the field and value
};

// The clock a work-budgeted solve keeps its deadline on. It reads a work meter (a WorkClock at the
// options' rates, charged by the prediction model) while the step's clock has not passed the guard;
// once it has, it reads no earlier than the meter's deadline, so every deadline check the solver
// makes fires and the solve ends as it would at its budget. Charges reach both the meter and the
// step's clock (a work clock in tests; the wall clock ignores them). One per controller; reads are
// thread-safe, begin() is not.
class WorkBudgetClock final : public Clock {
 public:
  explicit WorkBudgetClock(const WorkBudgetOptions& options);

  // Starts a step's budget: `work` seconds of work from now on the meter, guarded by `guard_at` on
  // `step_clock` (not owned; it must outlive the step). Returns the deadline on this clock.
  Deadline begin(const Clock& step_clock, TimePoint guard_at, Duration work) noexcept;
  TimePoint now() const noexcept override;
  void charge(double module_evaluations) const noexcept override;
  // Whether the guard cut this step's budget short (the answer then depends on the machine's speed).
  bool guard_fired() const noexcept { return guard_fired_.load(std::memory_order_relaxed); }

 private:
  WorkClock meter_;
  const Clock* step_clock_ = &steady_clock();
  TimePoint guard_at_ = TimePoint::max();
  TimePoint meter_deadline_{};
  mutable std::atomic<bool> guard_fired_{false};
};

}  // namespace swerve
