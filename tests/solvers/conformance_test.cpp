// One contract for every built backend (chosen by name through make_solver, as the controller
// does): the closed-form optimum of a linear-quadratic problem, input bounds, the wall-clock
// deadline, a usable plan on the swerve problem, and clear statuses for bad problems.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdint>
#include <limits>
#include <vector>

#include "support/model_fixtures.hpp"
#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "support/time_scale.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"
#include "swerve/sim/metrics.hpp"
#include "swerve/solvers/solver_factory.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;
using testing::DoubleIntegratorModel;

SolverConfig config_for(const std::string& backend) {
  SolverConfig config;
  config.backend = backend;
  config.sa.knots = 0;  // one knot per step: the LQ optimum is representable exactly
  config.sa.max_iterations = 40000;
  config.rti.max_iterations = 3000;    // iterated to convergence (1 per cycle is its real-time use)
  config.ipopt.max_iterations = 3000;  // the deadline stops it first
  config.ceres.max_iterations = 3000;
  return config;
}

// The controller's defaults (SA: six knots over the horizon) for the swerve problem.
SolverConfig swerve_config_for(const std::string& backend) {
  SolverConfig config;
  config.backend = backend;
  // A fixed amount of work (~4 s here); the deadline is a cap. 15000 reached 2.1 % once the stage
  // wear charged command changes only the lagged drives' share (flatter in the corrections).
  config.sa.max_iterations = 30000;
  config.rti.max_iterations = 3000;
  config.ipopt.max_iterations = 3000;
  config.ceres.max_iterations = 3000;
  return config;
}

// Documented tolerances on the LQ optimum's cost from a cold (zero) start: SA within 1 % (its own
// suite's figure), the gradient backends (Ipopt, NLopt's SLSQP, Ceres) within 1e-6.
double lq_tolerance(const std::string& backend) { return backend == "sa" ? 1e-2 : 1e-6; }

class BackendConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(BackendConformance, ReachesTheClosedFormOptimumOfALinearQuadraticProblem) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 6);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  Eigen::MatrixXd states(6, 7);
  const double optimal_cost = testing::evaluate_once(problem, optimum, states).total();
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
struct SwerveProblem : testing::SwerveTestProblem {
  SwerveProblem() : testing::SwerveTestProblem(testing::SwerveScene::kSidestep) {}
};

TEST_P(BackendConformance, ReturnsByAOneMillisecondDeadlineWithAUsablePlan) {
  // On a clock charged per model evaluation (10 us per step, 50 us with Jacobians: a rollout of
  // N = 20 "takes" 0.2 ms, a Jacobian rollout 1 ms), so the test is the same on any machine.
  SwerveProblem s;
  testing::WorkClock clock;
  const testing::ClockedModel model(s.model, &clock, 10e-6, 50e-6);
  const std::unique_ptr<OcpProblem> problem = testing::problem_on(model, s.problem);
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), *problem);
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  const TimePoint start = clock.now();
  const SolveStatus status = solver->solve(*problem, {}, Deadline(start + 1ms, clock), &solution, &summary);
  // Stated overhead: at most one rollout and the final evaluation past the deadline (0.4 ms).
  EXPECT_LE(clock.now() - start, 1ms + 400us) << to_string(status) << ": " << summary.reason;
  ASSERT_TRUE(has_solution(status)) << to_string(status) << ": " << summary.reason;
  EXPECT_TRUE(solution.inputs.allFinite());
  EXPECT_TRUE(problem->is_feasible(solution.inputs, 1e-9));
}

TEST_P(BackendConformance, ImprovesOnItsStartOnTheSwerveProblemAndNeverReturnsWorse) {
  // 200 ms on a clock charged per model evaluation (10 us per step, 50 us with Jacobians: 1000
  // rollouts or 200 Jacobian rollouts), the same budget on every machine and under any load.
  SwerveProblem s;
  testing::WorkClock clock;
  const testing::ClockedModel model(s.model, &clock, 10e-6, 50e-6);
  const std::unique_ptr<OcpProblem> problem = testing::problem_on(model, s.problem);
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), *problem);
  const Eigen::MatrixXd cruise = s.straight_on();
  InitialGuesses guesses;
  guesses.add(&cruise);
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(solver->solve(*problem, guesses, Deadline(clock.now() + 200ms, clock), &solution, &summary)))
      << summary.reason;
  Eigen::MatrixXd states(10, 21);
  const double start_cost = testing::evaluate_once(s.problem, cruise, states).total();
  EXPECT_LT(solution.cost, 0.9 * start_cost) << "start " << start_cost;
  EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
}

// The reference optimum of the swerve problem: Ipopt to tolerance 1e-9 from a cold start, no
// deadline (computed once; ~1 s).
double ipopt_reference_cost(const SwerveProblem& s) {
  static const double cost = [&] {
    SolverConfig config;
    config.backend = "ipopt";
    config.ipopt.tol = 1e-9;
    config.ipopt.max_iterations = 5000;
    std::unique_ptr<Solver> solver = make_solver(config, s.problem);
    Solution solution;
    solution.resize(10, 3, 20);
    SolveSummary summary;
    const SolveStatus status = solver->solve(s.problem, {}, SolverClock::now() + 600s, &solution, &summary);
    EXPECT_EQ(status, SolveStatus::kConverged) << summary.reason;
    return solution.cost;
  }();
  return cost;
}

// Stated gaps to the reference after a solve from the straight-ahead guess run to its own stopping
// rule: the gradient backends converge to the same local optimum (within 0.1 %; measured 0, with
// Ceres' Levenberg-Marquardt taking ~2700 iterations to get there); SA, a sampler, within 2 % after
// its 15000 proposals (deterministic for its seed: 0.14 % measured; 0.1-2.4 % when a 2 s deadline
// cut it short under load).
double reference_tolerance(const std::string& backend) { return backend == "sa" ? 2e-2 : 1e-3; }

// SA is a sampler: which basin a run ends in depends on its seed. Over seeds 1-15 a 30000-proposal
// run from the cruise guess ended 0.08-52 % above the reference (bimodal: near 0.1 % or 8-50 %,
// where the lateral twist rides the rate bound), before and after the prediction step's Newton
// solve changed at the 1e-10 level (issue 16). The claim tested for SA is therefore that it reaches
// the reference's basin from some of five seeds, every run respecting dynamics and bounds.
std::vector<std::uint64_t> seeds_for(const std::string& backend) {
  return backend == "sa" ? std::vector<std::uint64_t>{1, 2, 3, 4, 5} : std::vector<std::uint64_t>{1};
}

TEST_P(BackendConformance, ReachesTheIpoptReferenceOnTheSwerveProblemWithExactDynamics) {
  const std::vector<std::string>& built = built_backends();
  if (std::find(built.begin(), built.end(), "ipopt") == built.end()) {
    GTEST_SKIP() << "the reference optimum comes from the Ipopt backend, which this build lacks";
  }
  SwerveProblem s;
  const double reference = ipopt_reference_cost(s);
  double best_cost = std::numeric_limits<double>::infinity();
  for (const std::uint64_t seed : seeds_for(GetParam())) {
    SolverConfig config = swerve_config_for(GetParam());
    config.sa.seed = seed;
    std::unique_ptr<Solver> solver = make_solver(config, s.problem);
    const Eigen::MatrixXd cruise = s.straight_on();
    InitialGuesses guesses;
    guesses.add(&cruise);
    Solution solution;
    solution.resize(10, 3, 20);
    SolveSummary summary;
    const auto deadline =
        SolverClock::now() + std::chrono::duration_cast<SolverClock::duration>(60s * testing::kTimeScale);
    const SolveStatus status = solver->solve(s.problem, guesses, deadline, &solution, &summary);
    ASSERT_TRUE(has_solution(status)) << summary.reason;
    std::printf("[          ] %s (seed %llu): cost %.6f, reference %.6f, gap %+.3f %%, %d iterations, %.1f ms\n",
                GetParam().c_str(), static_cast<unsigned long long>(seed), solution.cost, reference,
                100.0 * (solution.cost / reference - 1.0), summary.iterations, 1e3 * summary.solve_time_s);
    best_cost = std::min(best_cost, solution.cost);
    // Dynamics respected: the plan's states are the model's rollout of its inputs (defect 0 <= 1e-6).
    Eigen::MatrixXd states(10, 21);
    testing::evaluate_once(s.problem, solution.inputs, states);
    EXPECT_LE((states - solution.states).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_TRUE(s.problem.is_feasible(solution.inputs, 1e-9));
  }
  EXPECT_LE(best_cost, reference * (1.0 + reference_tolerance(GetParam())));
}

TEST_P(BackendConformance, WarmStartFromTheShiftedPlanNeedsFewerIterationsThanACold) {
  // Per seed (SA: five, see seeds_for): the warm and cold plan costs and iteration counts.
  std::vector<double> warm_costs, cold_costs;
  for (const std::uint64_t seed : seeds_for(GetParam())) {
    SwerveProblem s;
    SolverConfig config = swerve_config_for(GetParam());
    config.sa.seed = seed;
    std::unique_ptr<Solver> solver = make_solver(config, s.problem);
    // No deadline may bind (SA spends its whole iteration budget, the others run to convergence):
    // on a clock that never moves, so a slow or loaded machine (or a sanitizer) cannot cut a solve.
    const WorkClock stopped;
    const Deadline generous(stopped.now() + std::chrono::seconds(10), stopped);
    Solution solution;
    solution.resize(10, 3, 20);
    SolveSummary summary;
    const Eigen::MatrixXd cruise = s.straight_on();
    InitialGuesses first_guess;
    first_guess.add(&cruise);
    ASSERT_TRUE(has_solution(solver->solve(s.problem, first_guess, generous, &solution, &summary)));
    // The next cycle: the state the plan predicts, the reference one step on.
    s.next_cycle(1, &solution);
    const Eigen::MatrixXd shifted = solution.inputs;
    InitialGuesses warm_guess;
    warm_guess.add(&shifted);
    SolveSummary warm, cold;
    ASSERT_TRUE(has_solution(solver->solve(s.problem, warm_guess, generous, &solution, &warm)));
    // Cold: a fresh solver from the last input held over the horizon (what a controller without a
    // previous plan would start from; all-zero inputs are a flat point of the body-twist model,
    // whose modules hold their angles at zero speed).
    std::unique_ptr<Solver> fresh = make_solver(config, s.problem);
    const Eigen::MatrixXd held = s.problem.previous_input().replicate(1, 20);
    InitialGuesses cold_guess;
    cold_guess.add(&held);
    Solution cold_solution;
    cold_solution.resize(10, 3, 20);
    ASSERT_TRUE(has_solution(fresh->solve(s.problem, cold_guess, generous, &cold_solution, &cold)));
    std::printf("[          ] %s (seed %llu): warm %d iterations (cost %.6f, %s), cold %d iterations (cost %.6f, %s)\n",
                GetParam().c_str(), static_cast<unsigned long long>(seed), warm.iterations, solution.cost, warm.reason,
                cold.iterations, cold_solution.cost, cold.reason);
    warm_costs.push_back(solution.cost);
    cold_costs.push_back(cold_solution.cost);
    if (GetParam() == "sa") {
      // SA has no convergence test: it spends its whole iteration budget either way.
      EXPECT_EQ(warm.iterations, cold.iterations);
    } else {
      EXPECT_LT(warm.iterations, cold.iterations);
      EXPECT_LE(solution.cost, cold_solution.cost * (1.0 + 1e-3));
    }
  }
  if (GetParam() == "sa") {
    // The same budget must buy a better plan from the warm start: over the seeds, the median
    // warm cost is below the median cold one (single runs cross either way, see seeds_for).
    EXPECT_LT(percentile(warm_costs, 50.0), percentile(cold_costs, 50.0));
  }
}

TEST_P(BackendConformance, RefusesAProblemOfAnotherShape) {
  SwerveProblem s;
  std::unique_ptr<Solver> solver = make_solver(config_for(GetParam()), s.problem);
  const DoubleIntegratorModel model(0.5);
  const OcpProblem other = testing::make_lq_problem(model, 20);
  Solution solution;
  solution.resize(6, 3, 20);
  SolveSummary summary;
  EXPECT_EQ(solver->solve(other, {}, SolverClock::now() + 1s, &solution, &summary), SolveStatus::kInvalidInput);
  EXPECT_FALSE(solution.valid);
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

TEST(NloptOptions, UnknownAlgorithmsAndBadValuesAreRejectedNamingTheField) {
  NloptOptions options;
  options.algorithm = "GN_DIRECT";  // a global method: not offered
  try {
    options.validate();
    FAIL() << "accepted GN_DIRECT";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("NloptOptions.algorithm = GN_DIRECT"), std::string::npos) << error.what();
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
