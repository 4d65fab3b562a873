// The Ceres backend's least-squares form (its residuals sum to the OCP cost, its Jacobian matches
// finite differences), the closed-form LQ optimum, the wall-clock deadline, the never-worse-than-
// the-start rule, and its options' validation.
#include "swerve/solvers/ceres_solver.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "support/model_fixtures.hpp"
#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "support/time_scale.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;
using testing::DoubleIntegratorModel;

double cost_of(const OcpProblem& problem, const Eigen::MatrixXd& inputs) {
  Eigen::MatrixXd states(problem.state_size(), problem.horizon() + 1);
  return testing::evaluate_once(problem, inputs, states).total();
}

// The turning scene of tests/support/swerve_problems.hpp, every cost term active.
struct SwerveProblem : testing::SwerveTestProblem {
  explicit SwerveProblem(int horizon, double max_step = 0.25)
      : testing::SwerveTestProblem(testing::SwerveScene::kTurn, horizon, max_step) {}
};

// Central differences of the residuals over every input of a 10-step, 3-input plan.
Eigen::MatrixXd finite_difference_jacobian(CeresSolver& solver, const OcpProblem& problem, const Eigen::MatrixXd& inputs) {
  const int rows = solver.residual_count();
  Eigen::VectorXd plus_residuals(rows), minus_residuals(rows);
  Eigen::MatrixXd fd(rows, 30);
  const double h = 1e-6;
  for (int k = 0; k < 10; ++k) {
    for (int i = 0; i < 3; ++i) {
      Eigen::MatrixXd plus = inputs, minus = inputs;
      plus(i, k) += h;
      minus(i, k) -= h;
      EXPECT_TRUE(solver.evaluate_residuals(problem, plus, plus_residuals, nullptr));
      EXPECT_TRUE(solver.evaluate_residuals(problem, minus, minus_residuals, nullptr));
      fd.col(3 * k + i) = (plus_residuals - minus_residuals) / (2 * h);
    }
  }
  return fd;
}

TEST(CeresSolver, HalfTheResidualSumOfSquaresIsTheOcpCostPlusTheWearSmoothingConstant) {
  SwerveProblem s(10);
  const Eigen::MatrixXd inputs = s.jittered_inputs(0.05, 7);
  ASSERT_TRUE(s.problem.is_feasible(inputs));  // so the step penalty is zero
  CeresSolver solver(s.problem, {});
  Eigen::VectorXd residuals(solver.residual_count());
  ASSERT_TRUE(solver.evaluate_residuals(s.problem, inputs, residuals, nullptr));
  Eigen::MatrixXd states(s.model.state_size(), 11);
  Eigen::VectorXd stage_costs(10);
  const double cost = testing::rollout_once(s.problem, inputs, 0, states, stage_costs);
  const double smoothing = 10 * CeresSolver::kWearSmoothing * CeresSolver::kWearSmoothing;
  EXPECT_NEAR(0.5 * residuals.squaredNorm() - smoothing, cost, 1e-12 * cost);
  // Every term is in play: wear and tracking both contribute.
  EXPECT_GT(testing::evaluate_once(s.problem, inputs, states).wear, 1e-3 * cost);
  EXPECT_GT(testing::evaluate_once(s.problem, inputs, states).tracking, 1e-3 * cost);
}

TEST(CeresSolver, StepPenaltyIsZeroOnFeasiblePlansAndPositiveOnInfeasibleOnes) {
  SwerveProblem s(10, 0.03);
  CeresSolver solver(s.problem, {});
  Eigen::VectorXd residuals(solver.residual_count());
  Eigen::MatrixXd states(s.model.state_size(), 11);
  Eigen::VectorXd stage_costs(10);
  const double smoothing = 10 * CeresSolver::kWearSmoothing * CeresSolver::kWearSmoothing;
  Eigen::MatrixXd inputs = s.jittered_inputs(0.05, 3);
  ASSERT_FALSE(s.problem.is_feasible(inputs));
  ASSERT_TRUE(solver.evaluate_residuals(s.problem, inputs, residuals, nullptr));
  EXPECT_GT(0.5 * residuals.squaredNorm() - smoothing, testing::rollout_once(s.problem, inputs, 0, states, stage_costs) + 1.0);
  s.problem.project(inputs);
  ASSERT_TRUE(solver.evaluate_residuals(s.problem, inputs, residuals, nullptr));
  const double cost = testing::rollout_once(s.problem, inputs, 0, states, stage_costs);
  EXPECT_NEAR(0.5 * residuals.squaredNorm() - smoothing, cost, 1e-12 * cost);
}

TEST(CeresSolver, ResidualJacobianMatchesCentralFiniteDifferences) {
  // Steps bounded at 0.03 against jitter of 0.05: some step penalties are active, some not.
  SwerveProblem s(10, 0.03);
  const Eigen::MatrixXd inputs = s.jittered_inputs(0.05, 11);
  CeresSolver solver(s.problem, {});
  const int rows = solver.residual_count();
  Eigen::VectorXd residuals(rows);
  Eigen::MatrixXd jacobian;
  ASSERT_TRUE(solver.evaluate_residuals(s.problem, inputs, residuals, &jacobian));
  ASSERT_EQ(jacobian.rows(), rows);
  ASSERT_EQ(jacobian.cols(), 30);
  const Eigen::MatrixXd fd = finite_difference_jacobian(solver, s.problem, inputs);
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 1.0);
  EXPECT_LT((jacobian - fd).cwiseAbs().maxCoeff(), 1e-5 * scale) << "max entry error at scale " << scale;
  // The residuals are causal: stage k's rows do not depend on later inputs.
  const int stage_rows = rows / 10;
  for (int k = 0; k + 1 < 10; ++k) {
    EXPECT_EQ(jacobian.block(k * stage_rows, 3 * (k + 1), stage_rows, 3 * (9 - k)).cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(CeresSolver, WithATrackingTubeTheResidualsStillSumToTheCostAndTheJacobianMatchesFiniteDifferences) {
  // A tube narrow enough that most stages leave it in position or heading (issue 15's tolerance).
  SwerveProblem s(10);
  for (int k = 1; k <= 10; ++k) ASSERT_TRUE(s.problem.set_tube(k, 0.002 * k, 0.001 * k));
  const Eigen::MatrixXd inputs = s.jittered_inputs(0.05, 7);
  ASSERT_TRUE(s.problem.is_feasible(inputs));
  CeresSolver solver(s.problem, {});
  const int rows = solver.residual_count();
  Eigen::VectorXd residuals(rows);
  Eigen::MatrixXd jacobian;
  ASSERT_TRUE(solver.evaluate_residuals(s.problem, inputs, residuals, &jacobian));
  Eigen::MatrixXd states(s.model.state_size(), 11);
  Eigen::VectorXd stage_costs(10);
  const double cost = testing::rollout_once(s.problem, inputs, 0, states, stage_costs);
  const double smoothing = 10 * CeresSolver::kWearSmoothing * CeresSolver::kWearSmoothing;
  EXPECT_NEAR(0.5 * residuals.squaredNorm() - smoothing, cost, 1e-12 * cost);
  ASSERT_GT(s.problem.tube_excess(states).maxCoeff(), 0.0);  // the tube term is in play
  const Eigen::MatrixXd fd = finite_difference_jacobian(solver, s.problem, inputs);
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_LT((jacobian - fd).cwiseAbs().maxCoeff(), 1e-5 * scale) << "max entry error at scale " << scale;
}

TEST(CeresSolver, ReachesTheClosedFormOptimumOfALinearQuadraticProblem) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 6);
  const double optimal_cost = cost_of(problem, testing::double_integrator_optimum(problem, model));
  for (const char* linear_solver : {"dense_qr", "dense_normal_cholesky"}) {
    CeresOptions options;
    options.linear_solver = linear_solver;
    CeresSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 6);
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, SolverClock::now() + 30s, &solution, &summary), SolveStatus::kConverged)
        << linear_solver << ": " << summary.reason;
    EXPECT_LE(solution.cost, optimal_cost * (1.0 + 1e-6)) << linear_solver << ": optimum " << optimal_cost;
    EXPECT_GE(solution.cost, optimal_cost * (1.0 - 1e-9)) << linear_solver;
    EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
    EXPECT_GT(summary.iterations, 0);
    EXPECT_GT(summary.rollouts, summary.iterations);
    EXPECT_GT(summary.initial_cost, solution.cost);
    RecordProperty(std::string("relative_gap_") + linear_solver, std::to_string(solution.cost / optimal_cost - 1.0));
  }
}

// Zero tolerances and no iteration limit: only the deadline can stop Ceres.
CeresOptions run_until_the_deadline() {
  CeresOptions options;
  options.max_iterations = 1000000;
  options.function_tolerance = options.gradient_tolerance = options.parameter_tolerance = 0.0;
  return options;
}

// The swerve problem on a clock charged per model evaluation: 10 us per step, 50 us per step with
// Jacobians (about the measured 1:5 ratio), so a Jacobian rollout at N = 20 "takes" 1 ms. Ceres'
// own linear algebra is free on this clock; the deadline logic is what is under test.
struct ClockedSwerveProblem {
  SwerveProblem s{20, 0.1};
  testing::WorkClock clock;
  testing::ClockedModel model{s.model, &clock, 10e-6, 50e-6};
  std::unique_ptr<OcpProblem> problem = testing::problem_on(model, s.problem);
};

TEST(CeresSolver, HonoursAFiveMillisecondDeadline) {
  ClockedSwerveProblem c;
  CeresSolver solver(*c.problem, run_until_the_deadline());
  Solution solution;
  solution.resize(c.model.state_size(), 3, 20);
  SolveSummary summary;
  const TimePoint start = c.clock.now();
  const SolveStatus status = solver.solve(*c.problem, {}, Deadline(start + 5ms, c.clock), &solution, &summary);
  // Two Jacobian evaluations are kept back for the evaluation in flight at the stop and the final
  // report, so the deadline holds exactly on a clock without scheduler noise.
  EXPECT_LE(c.clock.now() - start, 5ms) << summary.reason;
  ASSERT_EQ(status, SolveStatus::kBudgetExhausted) << summary.reason;
  EXPECT_TRUE(solution.valid);
  EXPECT_TRUE(c.problem->is_feasible(solution.inputs, 1e-12));
  EXPECT_LE(solution.cost, summary.initial_cost);
}

TEST(CeresSolver, KeepsTheStepsOfARunStoppedByTheDeadline) {
  // The deadline stops Ceres "successfully": an abort would make it restore its start.
  ClockedSwerveProblem c;
  CeresSolver solver(*c.problem, run_until_the_deadline());
  Solution solution;
  solution.resize(c.model.state_size(), 3, 20);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(*c.problem, {}, Deadline(c.clock.now() + 50ms, c.clock), &solution, &summary),
            SolveStatus::kBudgetExhausted)
      << summary.reason;
  EXPECT_GE(summary.iterations, 1);
  EXPECT_LT(solution.cost, summary.initial_cost);  // an abort would have returned the start itself
}

TEST(CeresSolver, IsNeverWorseThanItsBestInitialGuessAndStaysFeasible) {
  SwerveProblem s(20, 0.05);
  Eigen::MatrixXd guess = s.jittered_inputs(0.02, 5);
  s.problem.project(guess);
  Eigen::MatrixXd far_off = Eigen::MatrixXd::Constant(3, 20, 1.5);
  InitialGuesses guesses;
  guesses.add(&far_off);
  guesses.add(&guess);
  CeresOptions options;
  options.max_iterations = 1;  // too short to converge: the start must still bound the answer
  CeresSolver solver(s.problem, options);
  Solution solution;
  solution.resize(s.model.state_size(), 3, 20);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver.solve(s.problem, guesses, SolverClock::now() + 10s, &solution, &summary)))
      << summary.reason;
  EXPECT_DOUBLE_EQ(summary.initial_cost, cost_of(s.problem, guess));
  EXPECT_LE(solution.cost, summary.initial_cost);
  EXPECT_TRUE(s.problem.is_feasible(solution.inputs, 1e-12));
}

TEST(CeresSolver, RefusesAModelWithoutJacobians) {
  const testing::ModelWithoutJacobians model;
  const OcpProblem problem(model, 3, 0.1, CostWeights{}, InputBounds{});
  EXPECT_THROW(CeresSolver(problem, {}), ConfigError);
}

// A double integrator that claims Jacobians but whose steps fail once its speed reaches `failing_speed`.
class FailingModel final : public PredictionModel {
 public:
  explicit FailingModel(double failing_speed) : failing_speed_(failing_speed) {}
  int state_size() const noexcept override { return 6; }
  int input_size() const noexcept override { return 3; }
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
            Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override {
    return healthy_.step(data, x, u, dt, x_next, stage_wear) && x_next.segment<3>(3).norm() < failing_speed_;
  }
  bool has_jacobians() const noexcept override { return true; }
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                      Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b,
                      double* stage_wear, Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override {
    return healthy_.step_jacobians(data, x, u, dt, x_next, a, b, stage_wear, wear_gradient) &&
           x_next.segment<3>(3).norm() < failing_speed_;
  }

 private:
  DoubleIntegratorModel healthy_{0.5};
  double failing_speed_;
};

TEST(CeresSolver, ReportsANumericalErrorWhenTheModelFailsOnEveryStart) {
  const FailingModel failing(-1.0);  // every step fails
  const DoubleIntegratorModel healthy;
  const OcpProblem problem = testing::make_lq_problem(healthy, 5);
  const OcpProblem broken(failing, 5, 0.1, problem.weights(), InputBounds{});
  CeresSolver solver(broken, {});
  Solution solution;
  solution.resize(6, 3, 5);
  SolveSummary summary;
  EXPECT_EQ(solver.solve(broken, {}, SolverClock::now() + 10s, &solution, &summary), SolveStatus::kNumericalError);
  EXPECT_FALSE(solution.valid);
}

TEST(CeresSolver, TreatsModelFailuresAtTrialPointsAsRejectedStepsAndReturnsAUsablePlan) {
  // Steps fail above 0.25 m/s: the start (at rest) is fine, the unconstrained optimum is not.
  const FailingModel model(0.25);
  const DoubleIntegratorModel healthy;
  const OcpProblem reference = testing::make_lq_problem(healthy, 6);
  OcpProblem problem(model, 6, 0.1, reference.weights(), InputBounds{});
  for (int k = 1; k <= 6; ++k) problem.set_reference(k, reference.reference_poses().col(k - 1), Eigen::Vector3d::Zero());
  CeresSolver solver(problem, {});
  Solution solution;
  solution.resize(6, 3, 6);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver.solve(problem, {}, SolverClock::now() + 10s, &solution, &summary))) << summary.reason;
  EXPECT_TRUE(std::isfinite(solution.cost));
  EXPECT_LT(solution.cost, summary.initial_cost);
}

TEST(CeresOptions, RejectsBadValuesNamingTheField) {
  auto message_of = [](const CeresOptions& options) -> std::string {
    try {
      options.validate();
    } catch (const ConfigError& error) {
      return error.what();
    }
    return "accepted";
  };
  CeresOptions options;
  EXPECT_EQ(message_of(options), "accepted");
  options.max_iterations = 0;
  EXPECT_NE(message_of(options).find("CeresOptions.max_iterations = 0"), std::string::npos) << message_of(options);
  options = {};
  options.function_tolerance = -1.0;
  EXPECT_NE(message_of(options).find("CeresOptions.function_tolerance = -1"), std::string::npos);
  options = {};
  options.gradient_tolerance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(message_of(options).find("CeresOptions.gradient_tolerance"), std::string::npos);
  options = {};
  options.parameter_tolerance = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of(options).find("CeresOptions.parameter_tolerance"), std::string::npos);
  options = {};
  options.linear_solver = "sparse_schur";
  EXPECT_NE(message_of(options).find("CeresOptions.linear_solver = sparse_schur: must be dense_qr or"), std::string::npos)
      << message_of(options);
  options = {};
  options.step_penalty_weight = -2.0;
  EXPECT_NE(message_of(options).find("CeresOptions.step_penalty_weight = -2"), std::string::npos);
  // The constructor validates too.
  const DoubleIntegratorModel model;
  const OcpProblem problem = testing::make_lq_problem(model, 4);
  options = {};
  options.linear_solver = "";
  EXPECT_THROW(CeresSolver(problem, options), ConfigError);
}

}  // namespace
}  // namespace swerve
