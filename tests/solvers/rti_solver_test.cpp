// What only the real-time iteration backend promises beyond the conformance suite (which runs it to
// convergence with every other backend): one iteration per cycle from the shifted plan stays near
// the converged optimum of each cycle's problem, the line search never lets a step make the plan
// worse, a feedback on a prepared linearisation (the preparation/feedback split) takes the whole
// iteration's step on the start it prepared for and nearly its step on another, and bad options
// are named by their field (its allocation test: no_allocation_test.cpp).
#include "swerve/solvers/rti_solver.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <algorithm>
#include <cstdio>
#include <numeric>
#include <vector>
#include <string>

#include "support/config_errors.hpp"
#include "swerve/kinematics/module_state.hpp"  // wrap_angle, kPi
#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "support/one_off_steps.hpp"
#include "support/swerve_problems.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

// Gauss-Newton SQP run to convergence, without learnt curvature (which needs no memory to converge).
RtiOptions converging() {
  RtiOptions options;
  options.max_iterations = 500;
  options.tolerance = 1e-12;
  options.stage_quasi_newton = false;
  return options;
}

// A deadline no solve can reach: on a clock that never moves.
Deadline generous(const WorkClock& stopped) { return Deadline(stopped.now() + 10s, stopped); }

// Receding horizon on the sidestep problem: the real-time solver starts each cycle from its own
// shifted plan; a Gauss-Newton SQP run to convergence from the same plan sets each cycle's optimum.
// Returns the gap of each cycle's real-time plan to that optimum.
std::vector<double> real_time_gaps(const RtiOptions& options, int cycles) {
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  RtiSolver real_time(s.problem, options);
  RtiSolver reference(s.problem, converging());
  const WorkClock stopped;
  Solution plan;
  plan.resize(10, 3, 20);
  Eigen::MatrixXd held = s.problem.previous_input().replicate(1, 20);
  InitialGuesses cold;
  cold.add(&held);
  SolveSummary summary;
  EXPECT_TRUE(has_solution(reference.solve(s.problem, cold, generous(stopped), &plan, &summary)));
  std::vector<double> gaps;
  for (int cycle = 1; cycle <= cycles; ++cycle) {
    s.next_cycle(cycle, &plan);  // the plant follows the real-time plan
    Eigen::MatrixXd shifted = plan.inputs;
    InitialGuesses warm;
    warm.add(&shifted);
    EXPECT_TRUE(has_solution(real_time.solve(s.problem, warm, generous(stopped), &plan, &summary))) << summary.reason;
    EXPECT_LE(summary.iterations, options.max_iterations);
    Solution converged;
    converged.resize(10, 3, 20);
    EXPECT_TRUE(has_solution(reference.solve(s.problem, warm, generous(stopped), &converged, &summary)));
    gaps.push_back(plan.cost / converged.cost - 1.0);
  }
  return gaps;
}

TEST(RtiSolver, OneIterationPerCycleTracksEachCyclesOptimumOnceItsStageCurvatureIsLearnt) {
  const std::vector<double> with = real_time_gaps(RtiOptions{}, 15);
  for (std::size_t c = 0; c < with.size(); ++c) std::printf("[          ] cycle %2zu: gap %+.4f %%\n", c + 1, 100.0 * with[c]);
  // Measured: at most 3.6 % while the curvature is learnt (cycles 3-8), under 0.12 % from cycle 11.
  EXPECT_LE(*std::max_element(with.begin(), with.end()), 0.05);
  EXPECT_LE(*std::max_element(with.end() - 5, with.end()), 0.002);
  // Gauss-Newton alone misses the wear's and the dynamics' curvature: its steps overshoot, the line
  // search cuts them (to 1/32), and one iteration per cycle fell 20 % behind the optimum.
  RtiOptions gauss_newton;
  gauss_newton.stage_quasi_newton = false;
  const std::vector<double> without = real_time_gaps(gauss_newton, 15);
  EXPECT_GT(*std::max_element(without.begin(), without.end()), 0.1);
  EXPECT_LT(std::accumulate(with.end() - 5, with.end(), 0.0), 0.1 * std::accumulate(without.end() - 5, without.end(), 0.0));
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

TEST(RtiSolver, TriesAnIterationWhoseTimeIsUnknownAndStillEndsByTheDeadline) {
  // On a clock charged per model evaluation (10 us a step, 50 us a step with Jacobians): a rollout
  // of N = 20 costs 0.2 ms and a linearisation 1 ms. With 1.9 ms, the start's rollout, a
  // linearisation and the line search's rollout fit (1.4 ms). The first solve has no measured
  // iteration; a rule that priced it at ten rollouts (2 ms) never tried one, and on a 16-module
  // envelope draw the controller then only ever returned its start.
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  testing::WorkClock clock;
  const testing::ClockedModel model(s.model, &clock, 10e-6, 50e-6);
  const std::unique_ptr<OcpProblem> problem = testing::problem_on(model, s.problem);
  RtiSolver solver(*problem, RtiOptions{});
  const Eigen::MatrixXd cruise = s.straight_on();
  InitialGuesses guesses;
  guesses.add(&cruise);
  Solution solution;
  solution.resize(10, 3, 20);
  SolveSummary summary;
  const TimePoint start = clock.now();
  ASSERT_TRUE(has_solution(solver.solve(*problem, guesses, Deadline(start + 1900us, clock), &solution, &summary)))
      << summary.reason;
  EXPECT_EQ(summary.iterations, 1) << summary.reason;
  EXPECT_LT(solution.cost, summary.initial_cost);
  EXPECT_LE(clock.now() - start, 1900us);
  // With 1.1 ms the linearisation cannot finish: it gives up between stages, on time, and the start
  // is returned.
  const TimePoint second = clock.now();
  ASSERT_TRUE(has_solution(solver.solve(*problem, guesses, Deadline(second + 1100us, clock), &solution, &summary)));
  EXPECT_EQ(summary.iterations, 0) << summary.reason;
  EXPECT_LE(clock.now() - second, 1100us);
}

// Two solvers alike on the sidestep problem, one to prepare and one to solve whole, with the held
// input as their guess and a plan each.
struct SplitAndWhole {
  testing::SwerveTestProblem s{testing::SwerveScene::kSidestep};
  RtiSolver split, whole;
  const WorkClock stopped;
  Eigen::MatrixXd held = s.problem.previous_input().replicate(1, 20);
  InitialGuesses guesses;
  Solution prepared_plan, whole_plan;
  SolveSummary summary;
  explicit SplitAndWhole(const RtiOptions& options) : split(s.problem, options), whole(s.problem, options) {
    guesses.add(&held);
    prepared_plan.resize(10, 3, 20);
    whole_plan.resize(10, 3, 20);
  }
};

TEST(RtiSolver, AFeedbackOnTheStartItPreparedForTakesTheWholeIterationsStep) {
  SplitAndWhole fixture(RtiOptions{});
  auto& [s, split, whole, stopped, held, guesses, prepared_plan, whole_plan, summary] = fixture;
  ASSERT_TRUE(split.prepare(s.problem, guesses, generous(stopped)));
  ASSERT_TRUE(has_solution(split.solve(s.problem, guesses, generous(stopped), &prepared_plan, &summary)));
  EXPECT_TRUE(split.last_details().feedback);
  EXPECT_EQ(summary.rollouts, 1);  // the full step, judged against the start's estimated cost (exact here)
  ASSERT_TRUE(has_solution(whole.solve(s.problem, guesses, generous(stopped), &whole_plan, &summary)));
  EXPECT_FALSE(whole.last_details().feedback);
  EXPECT_LT(prepared_plan.cost, summary.initial_cost);
  EXPECT_LE((prepared_plan.inputs - whole_plan.inputs).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(prepared_plan.cost, whole_plan.cost, 1e-12 * whole_plan.cost);
}

TEST(RtiSolver, PreparedCyclesFollowAMeasuredStartThatDiffersFromThePredictedOne) {
  // Receding horizon on the sidestep problem where the plant does not do what was predicted: each
  // cycle's measured start is the predicted one pushed sideways and turned. The preparation sees
  // only the prediction; the feedback must still close much of the measured start's gap to the
  // optimum, about as much as a whole iteration linearised at the measured start does.
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  RtiSolver split(s.problem, RtiOptions{});
  RtiSolver whole(s.problem, RtiOptions{});
  RtiSolver reference(s.problem, converging());
  const WorkClock stopped;
  Solution plan, whole_plan, converged;
  plan.resize(10, 3, 20);
  whole_plan.resize(10, 3, 20);
  converged.resize(10, 3, 20);
  Eigen::MatrixXd held = s.problem.previous_input().replicate(1, 20);
  InitialGuesses cold;
  cold.add(&held);
  SolveSummary summary;
  ASSERT_TRUE(has_solution(reference.solve(s.problem, cold, generous(stopped), &plan, &summary)));
  double split_gaps = 0.0, whole_gaps = 0.0, start_gaps = 0.0;
  for (int cycle = 1; cycle <= 20; ++cycle) {
    s.next_cycle(cycle, &plan);  // the prediction, and the plant follows the split solver's plan
    Eigen::MatrixXd shifted = plan.inputs;
    InitialGuesses warm;
    warm.add(&shifted);
    ASSERT_TRUE(split.prepare(s.problem, warm, generous(stopped)));
    Eigen::VectorXd measured = s.problem.initial_state();
    const double sign = cycle % 2 == 0 ? 1.0 : -1.0;
    measured[1] += sign * 0.005;  // 5 mm sideways
    measured[2] += sign * 0.002;  // 0.002 rad
    measured[4] -= sign * 0.01;   // 1 cm/s sideways
    s.problem.set_initial_state(measured);
    ASSERT_TRUE(has_solution(split.solve(s.problem, warm, generous(stopped), &plan, &summary))) << summary.reason;
    ASSERT_TRUE(split.last_details().feedback);
    const double start_cost = summary.initial_cost;
    ASSERT_TRUE(has_solution(whole.solve(s.problem, warm, generous(stopped), &whole_plan, &summary)));
    if (cycle > 10) {  // the learnt curvature settled
      ASSERT_TRUE(has_solution(reference.solve(s.problem, warm, generous(stopped), &converged, &summary)));
      split_gaps += plan.cost / converged.cost - 1.0;
      whole_gaps += whole_plan.cost / converged.cost - 1.0;
      start_gaps += start_cost / converged.cost - 1.0;
    }
  }
  std::printf("[          ] mean gap over cycles 11-20: start %.4f %%, whole %.4f %%, prepared %.4f %%\n",
              10.0 * start_gaps, 10.0 * whole_gaps, 10.0 * split_gaps);
  EXPECT_LT(split_gaps, 0.5 * start_gaps);
  EXPECT_LT(split_gaps, 1.5 * whole_gaps + 1e-4);
}

TEST(RtiSolver, AFeedbackNeverReturnsAPlanWorseThanThePreparedPlanFromTheMeasuredStart) {
  // Without damping or the wear's curvature the model overshoots (see above), and the measured
  // starts here are far from the predicted one, so the start's cost the model predicts is
  // poor: steps it refuses must be judged against the prepared plan rolled out from the measured start.
  testing::SwerveTestProblem s(testing::SwerveScene::kTurn);
  RtiOptions bare;
  bare.damping = 0.0;
  bare.wear_curvature = false;
  const WorkClock stopped;
  Solution plan;
  plan.resize(10, 3, 20);
  SolveSummary summary;
  const Eigen::VectorXd predicted = s.problem.initial_state();
  int measured_starts = 0;
  for (unsigned seed = 1; seed <= 8; ++seed) {
    RtiSolver solver(s.problem, bare);
    s.problem.set_initial_state(predicted);
    Eigen::MatrixXd guess = s.jittered_inputs(0.2, seed);
    s.problem.project(guess);
    InitialGuesses guesses;
    guesses.add(&guess);
    ASSERT_TRUE(solver.prepare(s.problem, guesses, generous(stopped)));
    Eigen::VectorXd measured = predicted;
    measured[1] += 0.05 * static_cast<double>(seed);  // 5 to 40 cm sideways
    measured[2] -= 0.05 * static_cast<double>(seed);
    s.problem.set_initial_state(measured);
    ASSERT_TRUE(has_solution(solver.solve(s.problem, guesses, generous(stopped), &plan, &summary))) << summary.reason;
    ASSERT_TRUE(solver.last_details().feedback);
    measured_starts += summary.rollouts > 1 ? 1 : 0;
    Eigen::MatrixXd states(10, 21);
    const double start_cost = testing::evaluate_once(s.problem, guess, states).total();
    EXPECT_LE(plan.cost, start_cost * (1.0 + 1e-12)) << "seed " << seed;
    EXPECT_NEAR(plan.cost, testing::evaluate_once(s.problem, plan.inputs, states).total(), 1e-9 * plan.cost);
  }
  EXPECT_GT(measured_starts, 0);  // the estimate refused some step
}

TEST(RtiSolver, AFeedbackTakesAMeasuredHeadingWrappedAgainstItsPredictionAsTheSameHeading) {
  // A prediction carries the heading on past pi where a measurement wraps it: the two are the same
  // start (the cost wraps heading errors), so the feedback must be the same. Regression: the start's
  // change was 2 pi in heading, and a figure-eight wore 22 times what the whole iteration did.
  SplitAndWhole fixture(RtiOptions{});
  auto& [s, unwrapped, wrapped, stopped, held, guesses, plan, wrapped_plan, summary] = fixture;  // both prepare
  Eigen::VectorXd predicted = s.problem.initial_state();
  predicted[2] = kPi - 0.01;
  s.problem.set_initial_state(predicted);
  for (int k = 1; k <= 20; ++k) {
    s.problem.set_reference(k, s.problem.reference_poses().col(k - 1) + Eigen::Vector3d(0.0, 0.0, kPi - 0.01),
                            s.problem.reference_twists().col(k - 1));
  }
  Eigen::VectorXd measured = predicted;
  measured[1] += 0.01;
  measured[2] += 0.02;  // past pi
  for (RtiSolver* solver : {&unwrapped, &wrapped}) {
    s.problem.set_initial_state(predicted);
    ASSERT_TRUE(solver->prepare(s.problem, guesses, generous(stopped)));
  }
  s.problem.set_initial_state(measured);
  ASSERT_TRUE(has_solution(unwrapped.solve(s.problem, guesses, generous(stopped), &plan, &summary)));
  measured[2] = wrap_angle(measured[2]);  // as a measurement has it
  ASSERT_GT(std::abs(measured[2] - predicted[2]), 6.0);
  s.problem.set_initial_state(measured);
  ASSERT_TRUE(has_solution(wrapped.solve(s.problem, guesses, generous(stopped), &wrapped_plan, &summary)));
  EXPECT_TRUE(unwrapped.last_details().feedback);
  EXPECT_TRUE(wrapped.last_details().feedback);
  EXPECT_LE((plan.inputs - wrapped_plan.inputs).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(plan.cost, wrapped_plan.cost, 1e-9 * plan.cost);
}

TEST(RtiSolver, AProblemWithAnotherReferenceThanThePreparedOneGetsAWholeIteration) {
  RtiOptions options;
  options.stage_quasi_newton = false;  // no memory, so the two solvers start alike
  SplitAndWhole fixture(options);
  auto& [s, split, whole, stopped, held, guesses, plan, whole_plan, summary] = fixture;
  ASSERT_TRUE(split.prepare(s.problem, guesses, generous(stopped)));
  s.set_cycle(3);  // the reference moved on
  ASSERT_TRUE(has_solution(split.solve(s.problem, guesses, generous(stopped), &plan, &summary)));
  EXPECT_FALSE(split.last_details().feedback);
  ASSERT_TRUE(has_solution(whole.solve(s.problem, guesses, generous(stopped), &whole_plan, &summary)));
  EXPECT_LE((plan.inputs - whole_plan.inputs).cwiseAbs().maxCoeff(), 1e-12);
  // A preparation serves one solve: the next one, on the very problem prepared for, is whole too.
  ASSERT_TRUE(has_solution(split.solve(s.problem, guesses, generous(stopped), &plan, &summary)));
  EXPECT_FALSE(split.last_details().feedback);
}

TEST(RtiSolver, PreparationIsRefusedLikeASolveStoppedByItsDeadlineAndSwitchedOff) {
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  RtiSolver solver(s.problem, RtiOptions{});
  const WorkClock stopped;
  EXPECT_FALSE(solver.prepare(s.problem, {}, Deadline(stopped.now(), stopped)));  // already passed
  testing::SwerveTestProblem other(testing::SwerveScene::kSidestep, 10);
  EXPECT_FALSE(solver.prepare(other.problem, {}, generous(stopped)));  // another shape
  // A clock that moves a millisecond per reading: the linearisation gives up at the deadline.
  const WorkClock slow(1e-3);
  EXPECT_FALSE(solver.prepare(s.problem, {}, Deadline(slow.now() + 5ms, slow)));
  // And none at all with prepare off.
  RtiOptions whole_only;
  whole_only.prepare = false;
  RtiSolver whole(s.problem, whole_only);
  EXPECT_FALSE(whole.has_preparation());
  EXPECT_FALSE(whole.prepare(s.problem, {}, generous(stopped)));
  EXPECT_TRUE(solver.prepare(s.problem, {}, generous(stopped)));
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
