// What only the real-time iteration backend promises beyond the conformance suite (which runs it to
// convergence with every other backend): one iteration per cycle from the shifted plan stays near
// the converged optimum of each cycle's problem, the line search never lets a step make the plan
// worse, and bad options are named by their field (its allocation test: no_allocation_test.cpp).
#include "swerve/solvers/rti_solver.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "support/config_errors.hpp"
#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

RtiOptions converging() {
  RtiOptions options;
  options.max_iterations = 500;
  options.tolerance = 1e-12;
  return options;
}

// A deadline no solve can reach: on a clock that never moves.
Deadline generous(const WorkClock& stopped) { return Deadline(stopped.now() + 10s, stopped); }

TEST(RtiSolver, OneIterationPerCycleFromTheShiftedPlanStaysWithinAPercentOfEachCyclesOptimum) {
  // Receding horizon on the sidestep problem: both solvers start from their own shifted plan each
  // cycle; the converging one sets each cycle's optimum.
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  RtiOptions options;
  options.max_iterations = std::getenv("ITS") ? std::atoi(std::getenv("ITS")) : 5;
  RtiSolver real_time(s.problem, options);
  RtiSolver reference(s.problem, converging());
  const WorkClock stopped;
  Solution plan, optimum;
  plan.resize(10, 3, 20);
  optimum.resize(10, 3, 20);
  Eigen::MatrixXd held = s.problem.previous_input().replicate(1, 20);
  InitialGuesses cold;
  cold.add(&held);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(reference.solve(s.problem, cold, generous(stopped), &optimum, &summary)));
  plan = optimum;  // both begin at the first cycle's optimum
  double worst_gap = 0.0;
  for (int cycle = 1; cycle <= 15; ++cycle) {
    // The plant follows the real-time plan; the reference is re-solved on the same problem.
    s.next_cycle(cycle, &plan);
    Eigen::MatrixXd shifted = plan.inputs;
    InitialGuesses warm;
    warm.add(&shifted);
    ASSERT_TRUE(has_solution(real_time.solve(s.problem, warm, generous(stopped), &plan, &summary))) << summary.reason;
    Solution converged;
    converged.resize(10, 3, 20);
    ASSERT_TRUE(has_solution(reference.solve(s.problem, warm, generous(stopped), &converged, &summary)));
    const double gap = plan.cost / converged.cost - 1.0;
    std::printf("[          ] cycle %2d: real-time %.6f, converged %.6f, gap %+.4f %% (damping %g, fraction %g, qp %d)\n", cycle, plan.cost,
                converged.cost, 100.0 * gap, real_time.last_details().damping, real_time.last_details().step_fraction, real_time.last_details().qp_iterations);
    worst_gap = std::max(worst_gap, gap);
  }
  EXPECT_LE(worst_gap, 0.015);
}

TEST(RtiSolver, ReachesTheLinearQuadraticOptimumInputsWhenRunToConvergence) {
  const testing::DoubleIntegratorModel model(0.0);
  const OcpProblem problem = testing::make_lq_problem(model, 8);
  RtiOptions options = converging();
  options.damping = 0.0;  // the undamped Gauss-Newton step, which is Newton's here
  RtiSolver solver(problem, options);
  Solution solution;
  solution.resize(6, 3, 8);
  SolveSummary summary;
  const WorkClock stopped;
  ASSERT_EQ(solver.solve(problem, {}, generous(stopped), &solution, &summary), SolveStatus::kConverged) << summary.reason;
  // Gauss-Newton is exact here, so the first full step lands on the optimum; the second confirms it.
  EXPECT_LE(summary.iterations, 2);
  EXPECT_LT((solution.inputs - testing::double_integrator_optimum(problem, model)).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(RtiSolver, NeverReturnsAPlanWorseThanItsStartEvenWithoutDampingOrWearCurvature) {
  // Without the wear's curvature and without damping the model overshoots where the wear is steep
  // (from a start far from the reference); the line search must shorten or refuse such steps.
  testing::SwerveTestProblem s(testing::SwerveScene::kTurn);
  RtiOptions bare;
  bare.damping = 0.0;
  bare.wear_curvature = false;
  bare.max_iterations = 5;
  RtiSolver solver(s.problem, bare);
  const WorkClock stopped;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    Eigen::MatrixXd start = s.jittered_inputs(0.4, seed);
    s.problem.project(start);
    InitialGuesses guesses;
    guesses.add(&start);
    Solution solution;
    solution.resize(10, 3, 20);
    SolveSummary summary;
    ASSERT_TRUE(has_solution(solver.solve(s.problem, guesses, generous(stopped), &solution, &summary)));
    EXPECT_LE(solution.cost, summary.initial_cost) << "seed " << seed;
    EXPECT_TRUE(s.problem.is_feasible(solution.inputs, 1e-9));
  }
}

TEST(RtiSolver, RejectsBadOptionsNamingTheFieldAndValue) {
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  const auto message_for = [&](RtiOptions options) {
    return testing::config_error_of([&] { RtiSolver solver(s.problem, options); });
  };
  RtiOptions options;
  options.max_iterations = 0;
  EXPECT_NE(message_for(options).find("RtiOptions.max_iterations = 0"), std::string::npos) << message_for(options);
  options = RtiOptions{};
  options.tolerance = 0.0;
  EXPECT_NE(message_for(options).find("RtiOptions.tolerance = 0"), std::string::npos) << message_for(options);
  options = RtiOptions{};
  options.qp_tolerance = -1e-9;
  EXPECT_NE(message_for(options).find("RtiOptions.qp_tolerance"), std::string::npos) << message_for(options);
  options = RtiOptions{};
  options.qp_max_iterations = 0;
  EXPECT_NE(message_for(options).find("RtiOptions.qp_max_iterations = 0"), std::string::npos);
  options = RtiOptions{};
  options.line_search_steps = -1;
  EXPECT_NE(message_for(options).find("RtiOptions.line_search_steps = -1"), std::string::npos);
  options = RtiOptions{};
  options.damping = -1.0;
  EXPECT_NE(message_for(options).find("RtiOptions.damping = -1"), std::string::npos);
}

TEST(RtiSolver, RefusesAModelWithoutExactJacobians) {
  const testing::ModelWithoutJacobians model;
  CostWeights weights;
  const OcpProblem problem(model, 5, 0.1, weights, InputBounds{});
  EXPECT_NE(testing::config_error_of([&] { RtiSolver solver(problem, RtiOptions{}); }).find("Jacobians"),
            std::string::npos);
}

}  // namespace
}  // namespace swerve
