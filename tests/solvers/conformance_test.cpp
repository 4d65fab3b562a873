// One contract for every built backend (chosen by name through make_solver, as the controller
// does): the closed-form optimum of a linear-quadratic problem, input bounds, the wall-clock
// deadline, a usable plan on the swerve problem, and clear statuses for bad problems.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <limits>

#include "models/model_fixtures.hpp"
#include "support/linear_models.hpp"
#include "support/time_scale.hpp"
#include "swerve/mpc/twist_prediction_model.hpp"
#include "swerve/solvers/solver_factory.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;
using testing::DoubleIntegratorModel;

SolverConfig config_for(const std::string& backend) {
  SolverConfig config;
  config.backend = backend;
  config.sa.knots = 0;  // one knot per step: the LQ optimum is representable exactly
  config.sa.max_iterations = 40000;
  return config;
}

// Documented tolerances on the LQ optimum's cost from a cold (zero) start: SA within 1 % (its own
// suite's figure), NLopt's BOBYQA (a quadratic-model method) within 1e-6.
double lq_tolerance(const std::string& backend) { return backend == "sa" ? 1e-2 : 1e-6; }

class BackendConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(BackendConformance, ReachesTheClosedFormOptimumOfALinearQuadraticProblem) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 6);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  Eigen::MatrixXd states(6, 7);
  const double optimal_cost = problem.evaluate(optimum, states).total();
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), problem);
  Solution solution;
  solution.resize(6, 3, 6);
  SolveSummary summary;
  const SolveStatus status = solver->solve(problem, {}, SolverClock::now() + 30s, &solution, &summary);
  ASSERT_TRUE(has_solution(status)) << to_string(status) << ": " << summary.reason;
  EXPECT_LE(solution.cost, optimal_cost * (1.0 + lq_tolerance(GetParam()))) << "optimum " << optimal_cost;
  EXPECT_GE(solution.cost, optimal_cost * (1.0 - 1e-9));
  RecordProperty("relative_gap", std::to_string(solution.cost / optimal_cost - 1.0));
}

TEST_P(BackendConformance, KeepsEveryInputInsideItsBounds) {
  const DoubleIntegratorModel model(0.5);
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d::Constant(-0.2);
  bounds.upper = Eigen::Vector3d::Constant(0.2);
  bounds.max_step = Eigen::Vector3d::Constant(0.1);
  const OcpProblem problem = testing::make_lq_problem(model, 6, bounds);
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), problem);
  Solution solution;
  solution.resize(6, 3, 6);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver->solve(problem, {}, SolverClock::now() + 5s, &solution, &summary)));
  EXPECT_TRUE(problem.is_feasible(solution.inputs, 1e-12)) << solution.inputs;
  // The bounds are active: the unconstrained optimum needs more than 0.2.
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  EXPECT_GT(optimum.cwiseAbs().maxCoeff(), 0.2);
}

// The swerve problem the controller solves (4 modules, N = 20, body-twist inputs), moving at
// 0.5 m/s with a reference pulling 0.2 m aside.
struct SwerveProblem {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
  TwistPredictionModel model{params};
  OcpProblem problem;
  SwerveProblem() : problem(model, 20, 0.05, weights(), bounds()) {
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(10);
    x0[3] = 0.5;
    problem.set_initial_state(x0);
    problem.set_previous_input(Eigen::Vector3d(0.5, 0.0, 0.0));
    for (int k = 1; k <= 20; ++k) problem.set_reference(k, {0.025 * k, 0.2, 0.0}, {0.5, 0.0, 0.0});
  }
  static CostWeights weights() {
    CostWeights w;
    w.wear = std::getenv("SWERVE_WEAR0") ? 0.0 : 1.0;  // TEMP
    w.effort = Eigen::Vector3d::Zero();
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

TEST_P(BackendConformance, ReturnsByAOneMillisecondDeadlineWithAUsablePlan) {
  SwerveProblem s;
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), s.problem);
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  const auto start = SolverClock::now();
  const auto one_ms = std::chrono::duration_cast<SolverClock::duration>(1ms * testing::kTimeScale);
  const SolveStatus status = solver->solve(s.problem, {}, start + one_ms, &solution, &summary);
  const double elapsed_ms = std::chrono::duration<double, std::milli>(SolverClock::now() - start).count();
  // Stated overhead: one rollout and the final evaluation past the deadline, under 1 ms here.
  EXPECT_LT(elapsed_ms, 2.0 * testing::kTimeScale) << to_string(status);
  ASSERT_TRUE(has_solution(status)) << to_string(status) << ": " << summary.reason;
  EXPECT_TRUE(solution.inputs.allFinite());
  EXPECT_TRUE(s.problem.is_feasible(solution.inputs, 1e-9));
}

TEST_P(BackendConformance, ImprovesOnItsStartOnTheSwerveProblemAndNeverReturnsWorse) {
  SwerveProblem s;
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), s.problem);
  Eigen::MatrixXd cruise = Eigen::MatrixXd::Zero(3, 20);
  cruise.row(0).setConstant(0.5);  // keep going straight: feasible, not optimal (the reference is aside)
  InitialGuesses guesses;
  guesses.add(&cruise);
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver->solve(s.problem, guesses,
                                    SolverClock::now() + std::chrono::duration_cast<SolverClock::duration>(
                                                             200ms * testing::kTimeScale),
                                    &solution, &summary)))
      << summary.reason;
  Eigen::MatrixXd states(10, 21);
  const double start_cost = s.problem.evaluate(cruise, states).total();
  EXPECT_LT(solution.cost, 0.9 * start_cost) << "start " << start_cost;
  EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
}

TEST_P(BackendConformance, RejectsABadStateAndAPassedDeadlineBeforeSolving) {
  SwerveProblem s;
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), s.problem);
  OcpProblem bad = s.problem;
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(10);
  x0[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(bad.set_initial_state(x0));  // the problem refuses it and keeps its state
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  EXPECT_EQ(solver->solve(s.problem, {}, SolverClock::now() - 1ms, &solution, &summary), SolveStatus::kInvalidInput);
  EXPECT_FALSE(solution.valid);
}

INSTANTIATE_TEST_SUITE_P(EveryBuiltBackend, BackendConformance, ::testing::ValuesIn(built_backends()),
                         [](const ::testing::TestParamInfo<std::string>& backend) { return backend.param; });

TEST(NloptOptions, GradientAlgorithmsAreRejectedUntilExactDerivativesExist) {
  NloptOptions options;
  options.algorithm = "LD_SLSQP";
  try {
    options.validate();
    FAIL() << "accepted LD_SLSQP";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("NloptOptions.algorithm = LD_SLSQP"), std::string::npos) << error.what();
  }
  options = NloptOptions{};
  options.initial_step_fraction = 0.0;
  EXPECT_THROW(options.validate(), ConfigError);
  options = NloptOptions{};
  options.max_evaluations = 0;
  EXPECT_THROW(options.validate(), ConfigError);
}

}  // namespace
}  // namespace swerve
