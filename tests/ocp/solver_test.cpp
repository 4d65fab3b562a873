// The contract every backend gets from Solver::solve: how late a backend returned is measured on
// the deadline's clock and reported in its summary, never left to the caller to notice.
#include "swerve/ocp/solver.hpp"

#include <gtest/gtest.h>

#include <chrono>

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

}  // namespace
}  // namespace swerve
