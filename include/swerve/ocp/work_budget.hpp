// A solve budget counted in work rather than in time: the solve stops when the work it did, priced
// at a target's rates (per clock read, per module evaluation), reaches its share of the budget. The
// same inputs then get the same answer on every machine and in every run; the step's own clock,
// mapped onto the budget, takes over wherever the machine is slower than its rates say, so the
// solve still ends in time (docs/decisions/work-budget.md).
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

// The clock a work-budgeted solve keeps its deadline on: the later of two readings on the budget's
// scale. One is a work meter (a WorkClock at the options' rates, charged by the prediction model);
// the other is the step's clock, mapped so that reaching the guard reads as the end of the budget
// and a lag of up to kForgivenLag of the time to the guard (a cold first step, a stall) reads as
// none. On a machine as fast as its rates the meter is ahead and decides alone, so every run gives
// the same answer; on a slower one the step's clock is, and the solver's look-ahead ("does one
// more proposal fit?") sees the time proposals take, on the side of the deadline (1 / (1 - kForgivenLag)).
// Past the guard it reads the budget's end. Charges reach both the meter and the step's clock (a
// work clock in tests; the wall clock ignores them). One per controller; reads are thread-safe,
// begin() is not.
class WorkBudgetClock final : public Clock {
 public:
  explicit WorkBudgetClock(const WorkBudgetOptions& options);

  // The share of the time to the guard the step's clock may run behind the meter's pace before it
  // is read. A lag spread over the solve still reaches the guard in time; see
  // docs/decisions/work-budget.md.
  static constexpr double kForgivenLag = 0.5;

  // Starts a step's budget: `work` seconds of work from now on the meter, guarded by `guard_at` on
  // `step_clock` (not owned; it must outlive the step). Returns the deadline on this clock.
  Deadline begin(const Clock& step_clock, TimePoint guard_at, Duration work) noexcept;
  // Marks where the solver starts: from here the step's clock is mapped from the meter's reading,
  // so that what is left of its time to the guard reads as what is left of the budget. The step's
  // work before the solve (the baseline plan, the problem update) is priced only in part on the
  // meter; without this its wall time would put the step's clock ahead of the meter for the whole
  // solve. The reading may step back to the meter's here; durations a solver measures start after.
  void begin_solve() noexcept;
  TimePoint now() const noexcept override;
  void charge(double module_evaluations) const noexcept override;
  // Whether the step's clock was ahead of the meter at a read of this step's budget (the answer
  // may then depend on the machine's speed).
  bool guard_fired() const noexcept { return guard_fired_.load(std::memory_order_relaxed); }

 private:
  WorkClock meter_;
  const Clock* step_clock_ = &steady_clock();
  TimePoint guard_at_{};
  TimePoint step_start_{};      // the step's clock at begin() or begin_solve()
  TimePoint mapped_start_{};    // this clock's reading then
  TimePoint meter_deadline_{};  // the meter at begin() + the budget's work
  double step_to_meter_ = 0.0;  // ticks of this clock per tick of the step's clock until the guard
  void map_step_clock_from(TimePoint step_now, TimePoint reading) noexcept;
  mutable std::atomic<bool> guard_fired_{false};
};

}  // namespace swerve
