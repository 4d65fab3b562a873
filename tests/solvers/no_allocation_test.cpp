// The SQP backend's real-time path allocates nothing after construction: its QP, and a whole RTI
// solve after the first (allocations counted by hooking malloc; one file per test executable may).
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <chrono>

#include "support/allocation_counter.hpp"
#include "support/fake_clocks.hpp"
#include "support/swerve_problems.hpp"
#include "swerve/solvers/bounded_input_qp.hpp"
#include "swerve/solvers/rti_solver.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

TEST(BoundedInputQp, SolvesWithoutAllocating) {
  if (!testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting is unavailable in this build";
  const int nu = 3, horizon = 20, n = nu * horizon;
  const Eigen::MatrixXd h = Eigen::MatrixXd::Identity(n, n) + 0.5 * Eigen::MatrixXd::Ones(n, n);
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(n, -5.0, 5.0);
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d::Constant(-0.5);
  bounds.upper = Eigen::Vector3d::Constant(0.5);
  bounds.max_step = Eigen::Vector3d::Constant(0.1);
  const Eigen::VectorXd previous = Eigen::VectorXd::Zero(nu);
  BoundedInputQp qp(nu, horizon);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n);
  const BoundedInputQp::Settings settings;
  testing::AllocationCounter counter;
  const BoundedInputQp::Result result = qp.solve(h, q, bounds, previous, settings, z);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_TRUE(result.converged) << result.reason;
}

// The rti solver after its first solve of the sidestep problem, the problem one cycle on and the
// shifted plan its guess: where a controller's steady state begins.
struct RtiOneCycleOn {
  testing::SwerveTestProblem s{testing::SwerveScene::kSidestep};
  RtiSolver solver;
  const WorkClock stopped;
  Solution plan;
  Eigen::MatrixXd guess = s.problem.previous_input().replicate(1, 20);
  InitialGuesses guesses;
  SolveSummary summary;
  explicit RtiOneCycleOn(const RtiOptions& options) : solver(s.problem, options) {
    plan.resize(10, 3, 20);
    guesses.add(&guess);
  }
  void first_solve() {
    ASSERT_TRUE(has_solution(solver.solve(s.problem, guesses, deadline(), &plan, &summary)));
    s.next_cycle(1, &plan);
    guess = plan.inputs;
  }
  Deadline deadline() const { return Deadline(stopped.now() + 10s, stopped); }
};

TEST(RtiSolver, SolvesWithoutAllocatingAfterItsFirstSolve) {
  if (!testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting is unavailable in this build";
  RtiOptions options;
  options.max_iterations = 3;
  RtiOneCycleOn f(options);
  ASSERT_NO_FATAL_FAILURE(f.first_solve());
  const Deadline deadline = f.deadline();
  testing::AllocationCounter counter;
  const SolveStatus status = f.solver.solve(f.s.problem, f.guesses, deadline, &f.plan, &f.summary);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_TRUE(has_solution(status)) << f.summary.reason;
}

TEST(RtiSolver, PreparesAndFeedsBackWithoutAllocating) {
  if (!testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting is unavailable in this build";
  RtiOneCycleOn f(RtiOptions{});
  ASSERT_NO_FATAL_FAILURE(f.first_solve());
  Eigen::VectorXd measured = f.s.problem.initial_state();
  measured[1] += 0.01;
  const Deadline deadline = f.deadline();
  testing::AllocationCounter counter;
  const bool prepared = f.solver.prepare(f.s.problem, f.guesses, deadline);
  f.s.problem.set_initial_state(measured);
  const SolveStatus status = f.solver.solve(f.s.problem, f.guesses, deadline, &f.plan, &f.summary);
  EXPECT_EQ(counter.count(), 0);
  EXPECT_TRUE(prepared);
  EXPECT_TRUE(f.solver.last_details().feedback);
  EXPECT_TRUE(has_solution(status)) << f.summary.reason;
}

}  // namespace
}  // namespace swerve
