// The work budget's clock: it reads the work done at its own rates while the step's clock is
// before the guard, and no earlier than the budget's end once it is past; charges reach both.
#include "swerve/ocp/work_budget.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

WorkBudgetOptions rates(double per_read, double per_evaluation) {
  WorkBudgetOptions options;
  options.enabled = true;
  options.seconds_per_read = per_read;
  options.seconds_per_module_evaluation = per_evaluation;
  return options;
}

TEST(WorkBudgetClock, ADeadlineOnItPassesAfterTheBudgetsWorkWhateverTheStepsClockReads) {
  // 1 ms per read, 10 us per module evaluation, a 10 ms budget: begin() reads once (t = 1 ms, the
  // deadline 11 ms); 500 evaluations add 5 ms; reads at 7, 8, 9, 10 ms are before it, the 5th at 11 ms is not.
  WorkBudgetClock clock(rates(1e-3, 1e-5));
  const WorkClock step_clock;  // a machine infinitely fast: its clock stands still
  const Deadline deadline = clock.begin(step_clock, step_clock.now() + to_duration(1e-3), to_duration(10e-3));
  clock.charge(500.0);
  int reads_before_passing = 0;
  while (!deadline.passed()) ++reads_before_passing;
  EXPECT_EQ(reads_before_passing, 4);
  EXPECT_FALSE(clock.guard_fired());
}

TEST(WorkBudgetClock, PastTheGuardItReadsTheBudgetsEndSoTheDeadlinePassesAndSaysSo) {
  WorkBudgetClock clock(rates(1e-6, 1e-9));
  WorkClock step_clock;
  const Deadline deadline = clock.begin(step_clock, step_clock.now() + to_duration(5e-3), to_duration(1.0));
  EXPECT_FALSE(deadline.passed());
  step_clock.advance(to_duration(5e-3));  // the machine stalled: the guard is reached
  EXPECT_TRUE(deadline.passed());
  EXPECT_EQ(clock.now(), deadline.at());  // no further than the budget's end: durations stay bounded
  EXPECT_TRUE(clock.guard_fired());
  // The next step starts afresh.
  const Deadline next = clock.begin(step_clock, step_clock.now() + to_duration(5e-3), to_duration(1.0));
  EXPECT_FALSE(clock.guard_fired());
  EXPECT_FALSE(next.passed());
}

TEST(WorkBudgetClock, ChargesReachTheMeterAndTheStepsClock) {
  WorkBudgetClock clock(rates(1e-6, 2e-6));
  const WorkClock step_clock(0.0, 1e-6);  // a work clock of a test run: it prices evaluations too
  (void)clock.begin(step_clock, TimePoint::max(), to_duration(1.0));
  const TimePoint meter_before = clock.now(), step_before = step_clock.now();
  clock.charge(1000.0);
  EXPECT_EQ(clock.now() - meter_before, to_duration(1e-6 + 2e-3));  // the read and the charge
  // The meter's reads read the step's clock too (the guard), at its own rate of 0 per read.
  EXPECT_EQ(step_clock.now() - step_before, to_duration(1e-3));
}

TEST(WorkBudgetOptions, RefusesARateThatIsNotPositiveNamingTheField) {
  for (const double bad : {0.0, -1e-6, std::numeric_limits<double>::quiet_NaN()}) {
    try {
      WorkBudgetClock clock(rates(bad, 1e-7));
      ADD_FAILURE() << "accepted seconds_per_read " << bad;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find("seconds_per_read"), std::string::npos) << error.what();
    }
  }
  try {
    WorkBudgetClock clock(rates(1e-6, -1.0));
    ADD_FAILURE() << "accepted a negative seconds_per_module_evaluation";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("seconds_per_module_evaluation"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace swerve
