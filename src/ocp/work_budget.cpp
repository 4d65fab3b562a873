#include "swerve/ocp/work_budget.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
  const TimePoint step_now = step_clock.now();
  const TimePoint meter_now = meter_.now();
  meter_deadline_ = meter_now + work;
  map_step_clock_from(step_now, meter_now);
  return Deadline(meter_deadline_, *this);
}

void WorkBudgetClock::begin_solve() noexcept {
  // From the meter's reading: the step's clock being ahead before the solve (work the meter prices
  // in part) is forgiven, and only the solve's own pace is compared. A step's clock already ahead
  // decided nothing but that the solve may start.
  const TimePoint step_now = step_clock_->now();
  guard_fired_.store(false, std::memory_order_relaxed);
  map_step_clock_from(step_now, meter_.now());
}

void WorkBudgetClock::map_step_clock_from(TimePoint step_now, TimePoint reading) noexcept {
  step_start_ = step_now;
  mapped_start_ = std::min(reading, meter_deadline_);
  const auto to_guard = (guard_at_ - step_now).count();
  // A guard already reached maps every reading to the budget's end.
  step_to_meter_ = to_guard > 0 ? static_cast<double>((meter_deadline_ - mapped_start_).count()) /
                                      static_cast<double>(to_guard)
                                : std::numeric_limits<double>::infinity();
}

TimePoint WorkBudgetClock::now() const noexcept {
  const TimePoint metered = meter_.now();
  const double step_elapsed = static_cast<double>((step_clock_->now() - step_start_).count());
  const double left = static_cast<double>((meter_deadline_ - mapped_start_).count());
  // No further than the budget's end: a duration a solver measures across it then stays bounded.
  const double mapped_elapsed =
      std::isinf(step_to_meter_)
          ? left
          : std::min(left, std::max(0.0, (step_elapsed * step_to_meter_ - kForgivenLag * left) / (1.0 - kForgivenLag)));
  const TimePoint mapped = mapped_start_ + Duration(static_cast<Duration::rep>(std::llround(mapped_elapsed)));
  if (mapped <= metered) return metered;
  guard_fired_.store(true, std::memory_order_relaxed);
  return mapped;
}

void WorkBudgetClock::charge(double module_evaluations) const noexcept {
  meter_.charge(module_evaluations);
  step_clock_->charge(module_evaluations);
}

}  // namespace swerve
