// What only the Ipopt backend promises beyond the shared conformance suite: the multiple-shooting
// transcription converges with dynamics defects under 1e-6 and returns its rollout, a warm start
// from the shifted previous plan needs fewer iterations than a cold start, bad options name their
// field, and a failure is a status the controller falls back on.
#include "swerve/solvers/ipopt_solver.hpp"

#include <gtest/gtest.h>

#include "models/model_fixtures.hpp"
#include "support/linear_models.hpp"
#include "swerve/config/config_error.hpp"
#include "swerve/mpc/twist_prediction_model.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

// The conformance suite's swerve problem: 4 modules, N = 20, reference 0.2 m aside at 0.5 m/s.
struct SwerveProblem {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
  TwistPredictionModel model{params};
  OcpProblem problem;
  SwerveProblem() : problem(model, 20, 0.05, weights(), bounds()) {
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(10);
    x0[3] = 0.5;
    problem.set_initial_state(x0);
    problem.set_previous_input(Eigen::Vector3d(0.5, 0.0, 0.0));
    set_cycle(0);
  }
  void set_cycle(int cycle) {
    for (int k = 1; k <= 20; ++k) problem.set_reference(k, {0.025 * (k + cycle), 0.2, 0.0}, {0.5, 0.0, 0.0});
  }
  static CostWeights weights() {
    CostWeights w;
    w.wear = 1.0;
    w.rate = Eigen::Vector3d::Constant(1.0);
    return w;
  }
  static InputBounds bounds() {
    InputBounds b;
    b.upper = Eigen::Vector3d(2.0, 2.0, 4.0);
    b.lower = -b.upper;
    b.max_step = Eigen::Vector3d(0.1, 0.1, 0.25);
    return b;
  }
};

IpoptOptions tight() {
  IpoptOptions options;
  options.tol = 1e-8;
  options.max_iterations = 3000;
  return options;
}

TEST(IpoptSolver, ConvergesOnTheSwerveProblemWithDefectsUnderOneMicro) {
  SwerveProblem s;
  IpoptSolver solver(s.problem, tight());
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(s.problem, {}, SolverClock::now() + 60s, &solution, &summary), SolveStatus::kConverged)
      << summary.reason;
  EXPECT_LE(summary.max_defect, 1e-6);
  // The plan is the rollout of the inputs: its states are the model's, exactly.
  Eigen::MatrixXd states(10, 21);
  EXPECT_NEAR(s.problem.evaluate(solution.inputs, states).total(), solution.cost, 1e-12 * solution.cost);
  EXPECT_LT((states - solution.states).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(s.problem.is_feasible(solution.inputs, 1e-9));
}

TEST(IpoptSolver, WarmStartFromTheShiftedPlanTakesFewerIterationsThanACold) {
  SwerveProblem s;
  IpoptSolver solver(s.problem, tight());
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver.solve(s.problem, {}, SolverClock::now() + 60s, &solution, &summary)));
  // Next cycle: the state the plan predicted, the reference one step on.
  s.problem.set_initial_state(solution.states.col(1));
  s.problem.set_previous_input(solution.inputs.col(0));
  s.set_cycle(1);
  solution.shift();
  const Eigen::MatrixXd shifted = solution.inputs;
  InitialGuesses warm_guess;
  warm_guess.add(&shifted);
  SolveSummary warm, cold;
  ASSERT_TRUE(has_solution(solver.solve(s.problem, warm_guess, SolverClock::now() + 60s, &solution, &warm)));
  IpoptSolver fresh(s.problem, tight());
  Solution cold_solution;
  cold_solution.resize(10, 3, 20);
  ASSERT_TRUE(has_solution(fresh.solve(s.problem, {}, SolverClock::now() + 60s, &cold_solution, &cold)));
  RecordProperty("warm_iterations", warm.iterations);
  RecordProperty("cold_iterations", cold.iterations);
  EXPECT_LT(warm.iterations, cold.iterations);
  EXPECT_NEAR(solution.cost, cold_solution.cost, 1e-4 * cold_solution.cost);
}

TEST(IpoptSolver, ReachesTheLinearQuadraticOptimumToOneMicroRelative) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 8);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  Eigen::MatrixXd states(6, 9);
  const double optimal_cost = problem.evaluate(optimum, states).total();
  IpoptSolver solver(problem, tight());
  Solution solution;
  solution.resize(6, 3, 8);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(problem, {}, SolverClock::now() + 10s, &solution, &summary), SolveStatus::kConverged);
  EXPECT_NEAR(solution.cost, optimal_cost, 1e-6 * optimal_cost);
  EXPECT_LT((solution.inputs - optimum).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(IpoptSolver, RejectsBadOptionsNamingTheField) {
  SwerveProblem s;
  auto expect_rejected = [&](IpoptOptions options, const std::string& field) {
    try {
      IpoptSolver solver(s.problem, options);
      FAIL() << field << " accepted";
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find("IpoptOptions." + field), std::string::npos) << error.what();
    }
  };
  IpoptOptions options;
  options.tol = -1.0;
  expect_rejected(options, "tol");
  options = IpoptOptions{};
  options.mu_strategy = "probing";
  expect_rejected(options, "mu_strategy");
  options = IpoptOptions{};
  options.linear_solver = "ma57";
  expect_rejected(options, "linear_solver");
  options = IpoptOptions{};
  options.max_iterations = 0;
  expect_rejected(options, "max_iterations");
}

TEST(IpoptSolver, RefusesAProblemOfAnotherShape) {
  SwerveProblem s;
  IpoptSolver solver(s.problem, IpoptOptions{});
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem other = testing::make_lq_problem(model, 20);
  Solution solution;
  solution.resize(6, 3, 20);
  SolveSummary summary;
  EXPECT_EQ(solver.solve(other, {}, SolverClock::now() + 1s, &solution, &summary), SolveStatus::kInvalidInput);
  EXPECT_FALSE(solution.valid);
}

}  // namespace
}  // namespace swerve
