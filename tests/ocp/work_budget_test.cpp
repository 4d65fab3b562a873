// The work budget's clock: it reads the later of the work done at its own rates and the step's
// clock mapped onto the budget (the guard at the budget's end); charges reach both.
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

TEST(WorkBudgetClock, OnAMachineSlowerThanItsRatesItReadsTheStepsClockMappedOntoTheBudget) {
  // A 1 ms budget of work, guarded 2 ms later on the step's clock; the meter (1 ns per read)
  // stands almost still. The step's clock reads as the budget's share (u - 0.5) / 0.5 at the
  // share u of the time to the guard: nothing up to 1 ms, all of it at 2 ms.
  static_assert(WorkBudgetClock::kForgivenLag == 0.5, "the expectations below are for 0.5");
  WorkBudgetClock clock(rates(1e-9, 1e-12));
  WorkClock step_clock;
  const Deadline deadline = clock.begin(step_clock, step_clock.now() + to_duration(2e-3), to_duration(1e-3));
  const TimePoint start = deadline.at() - to_duration(1e-3);
  step_clock.advance(to_duration(800e-6));  // a lag within the forgiven share: the meter reads
  EXPECT_LT(clock.now() - start, to_duration(1e-8));
  EXPECT_FALSE(clock.guard_fired());
  step_clock.advance(to_duration(400e-6));  // u = 0.6
  EXPECT_EQ(clock.now() - start, to_duration(200e-6));
  EXPECT_TRUE(clock.guard_fired());
  // From here a 0.4 ms proposal reads as 0.4 ms of the budget: a solver asking whether one more
  // fits sees the time it takes (twice its share of the budget, on the side of the deadline).
  step_clock.advance(to_duration(400e-6));
  EXPECT_EQ(clock.now() - start, to_duration(600e-6));
  EXPECT_FALSE(deadline.passed());
  step_clock.advance(to_duration(400e-6));  // the guard
  EXPECT_TRUE(deadline.passed());
}

TEST(WorkBudgetClock, FromTheSolvesStartOnlyTheSolvesOwnPaceIsComparedWithTheMeter) {
  // 1 ms of budget guarded 2 ms later; the step's work before the solve took 1.2 ms of the step's
  // clock and almost nothing on the meter. Before begin_solve() the step's clock reads
  // (0.6 - 0.5) / 0.5 = 0.2 ms of the budget gone; from the solve's start the 0.8 ms left to the
  // guard maps onto the ~1 ms of work left, and the lag before the solve is forgiven.
  WorkBudgetClock clock(rates(1e-9, 1e-12));
  WorkClock step_clock;
  const Deadline deadline = clock.begin(step_clock, step_clock.now() + to_duration(2e-3), to_duration(1e-3));
  const TimePoint start = deadline.at() - to_duration(1e-3);
  step_clock.advance(to_duration(1.2e-3));
  EXPECT_EQ(clock.now() - start, to_duration(200e-6));
  clock.begin_solve();
  EXPECT_FALSE(clock.guard_fired());
  EXPECT_LT(clock.now() - start, to_duration(1e-8));  // the meter's reading again
  step_clock.advance(to_duration(600e-6));  // u = 0.75 of the time left: (0.75 - 0.5) / 0.5 of the work left
  EXPECT_NEAR(to_seconds(clock.now() - start), 500e-6, 1e-8);
  EXPECT_TRUE(clock.guard_fired());
  step_clock.advance(to_duration(200e-6));  // the guard
  EXPECT_TRUE(deadline.passed());
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
