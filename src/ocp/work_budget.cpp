#include "swerve/ocp/work_budget.hpp"

#include <algorithm>

namespace swerve {

const OptionFields<WorkBudgetOptions>& WorkBudgetOptions::fields() {
  static const OptionFields<WorkBudgetOptions> table{
      {"enabled", &WorkBudgetOptions::enabled},
      {"seconds_per_read", &WorkBudgetOptions::seconds_per_read, Bound::positive(), {}, nullptr,
       "(s on the target)"},
      {"seconds_per_module_evaluation", &WorkBudgetOptions::seconds_per_module_evaluation, Bound::positive(), {},
       nullptr, "(s on the target)"},
  };
  return table;
}

void WorkBudgetOptions::validate() const { check_fields("WorkBudgetOptions", *this, fields()); }

WorkBudgetClock::WorkBudgetClock(const WorkBudgetOptions& options)
    : meter_((options.validate(), options.seconds_per_read), options.seconds_per_module_evaluation) {}

Deadline WorkBudgetClock::begin(const Clock& step_clock, TimePoint guard_at, Duration work) noexcept {
  step_clock_ = &step_clock;
  guard_at_ = guard_at;
  guard_fired_.store(false, std::memory_order_relaxed);
  meter_deadline_ = meter_.now() + work;
  return Deadline(meter_deadline_, *this);
}

TimePoint WorkBudgetClock::now() const noexcept {
  const TimePoint metered = meter_.now();
  if (step_clock_->now() < guard_at_) return metered;
  guard_fired_.store(true, std::memory_order_relaxed);
  // No further: a duration a solver measures across the cut then stays within its budget.
  return std::max(metered, meter_deadline_);
}

void WorkBudgetClock::charge(double module_evaluations) const noexcept {
  meter_.charge(module_evaluations);
  step_clock_->charge(module_evaluations);
}

}  // namespace swerve
