// The contract every backend gets from Solver::solve: how late a backend returned is measured on
// the deadline's clock and reported in its summary, never left to the caller to notice.
#include "swerve/ocp/solver.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>

#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

// Takes the first guess and spends `work` of the test's clock on it, as a backend stalled by the
// operating system (or by a step it cannot interrupt) would.
class StalledSolver final : public Solver {
 public:
  StalledSolver(const OcpProblem& shape, testing::ManualClock* clock, Duration work)
      : Solver(shape), clock_(clock), work_(work), start_(shape) {}
  const char* name() const noexcept override { return "stalled"; }

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override {
    out->cost = start_.choose(problem, guesses, deadline);
    out->inputs = start_.inputs();
    out->states = start_.states();
    clock_->advance(work_);
    summary->reason = "returned its start";
    return SolveStatus::kBudgetExhausted;
  }
  testing::ManualClock* clock_;
  Duration work_;
  StartPlan start_;
};

TEST(Solver, ReportsHowFarPastItsDeadlineABackendReturnedAndZeroWhenOnTime) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 10);
  Solution solution;
  solution.resize(problem.state_size(), problem.input_size(), problem.horizon());
  for (const Duration work : {Duration(4ms), Duration(10ms), Duration(13500us)}) {
    SCOPED_TRACE(::testing::Message() << "work " << to_seconds(work) * 1e3 << " ms on a 10 ms deadline");
    testing::ManualClock clock;
    StalledSolver solver(problem, &clock, work);
    SolveSummary summary;
    const SolveStatus status = solver.solve(problem, {}, Deadline(clock.now() + 10ms, clock), &solution, &summary);
    EXPECT_EQ(status, SolveStatus::kBudgetExhausted);  // the backend's status stands; lateness is its own field
    EXPECT_TRUE(solution.valid);
    EXPECT_DOUBLE_EQ(summary.solve_time_s, to_seconds(work));
    EXPECT_DOUBLE_EQ(summary.late_s, work > 10ms ? to_seconds(work - 10ms) : 0.0);
  }
}

TEST(Solver, ReportsNoLatenessForAProblemItRefusesBeforeAnyBackendRuns) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 10);
  Solution solution;
  solution.resize(problem.state_size(), problem.input_size(), problem.horizon());
  testing::ManualClock clock;
  clock.advance(1s);
  StalledSolver solver(problem, &clock, 5ms);
  SolveSummary summary;
  // A deadline already past: refused at once, which is no late return of a backend.
  EXPECT_EQ(solver.solve(problem, {}, Deadline(clock.now() - 1ms, clock), &solution, &summary),
            SolveStatus::kInvalidInput);
  EXPECT_EQ(summary.late_s, 0.0);
  EXPECT_FALSE(solution.valid);
}

// A plan of 4 steps whose inputs and states are their own time index (+ 10 for states), so an
// interpolated column reads as the time it stands for.
Solution indexed_plan() {
  Solution plan;
  plan.resize(2, 1, 4);
  for (int k = 0; k < 4; ++k) plan.inputs(0, k) = k;
  for (int k = 0; k <= 4; ++k) plan.states.col(k).setConstant(10.0 + k);
  return plan;
}

TEST(Solution, ShiftByAFractionOfAStepInterpolatesEachColumnAtItsNewTime) {
  Solution plan = indexed_plan();
  plan.shift(0.5);  // a 25 ms period on a 50 ms prediction step
  // Column k is now the plan at k + 0.5; the last column stands for every time past it.
  EXPECT_DOUBLE_EQ(plan.inputs(0, 0), 0.5);
  EXPECT_DOUBLE_EQ(plan.inputs(0, 2), 2.5);
  EXPECT_DOUBLE_EQ(plan.inputs(0, 3), 3.0);
  EXPECT_DOUBLE_EQ(plan.states(1, 0), 10.5);
  EXPECT_DOUBLE_EQ(plan.states(0, 3), 13.5);
  EXPECT_DOUBLE_EQ(plan.states(0, 4), 14.0);
  plan.shift(1.5);  // then at k + 2 of the first plan (inside the columns the first shift kept)
  EXPECT_DOUBLE_EQ(plan.inputs(0, 0), 2.0);
  EXPECT_DOUBLE_EQ(plan.states(0, 0), 12.0);
  EXPECT_DOUBLE_EQ(plan.states(0, 1), 13.0);
}

TEST(Solution, ShiftByOneStepIsTheWholeStepShiftBitForBit) {
  Solution whole = indexed_plan();
  whole.inputs(0, 1) = 0.1;  // a value the interpolation (1 - 0) x + 0 y would keep, but say so
  Solution by_one = whole;
  whole.shift();
  by_one.shift(1.0);
  EXPECT_EQ(by_one.inputs, whole.inputs);
  EXPECT_EQ(by_one.states, whole.states);
}

TEST(Solution, ShiftByNoStepOrANonFiniteOneLeavesThePlan) {
  const Solution plan = indexed_plan();
  for (const double steps : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    Solution copy = plan;
    copy.shift(steps);
    EXPECT_EQ(copy.inputs, plan.inputs) << steps;
    EXPECT_EQ(copy.states, plan.states) << steps;
  }
  Solution far = plan;
  far.shift(1e6);  // past the end: the last column everywhere
  EXPECT_TRUE((far.inputs.array() == 3.0).all());
  EXPECT_TRUE((far.states.array() == 14.0).all());
}

}  // namespace
}  // namespace swerve
