// Simulated annealing against closed-form optima, and its contract: bounds, deadline, best plan
// returned, use of a larger budget, warm-start benefit, determinism by seed, failure statuses; and
// the gradient polish of its best plan (closer to the optimum, on time), and the knot polish on
// forward differences where no exact gradient fits.
#include "swerve/solvers/sa_solver.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>

#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "swerve/core/config_error.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

using testing::DoubleIntegratorModel;
using testing::make_lq_problem;
using namespace std::chrono_literals;

Deadline far_deadline() { return SolverClock::now() + 60s; }

double cost_of(const OcpProblem& problem, const Eigen::MatrixXd& inputs) {
  Eigen::MatrixXd states(problem.state_size(), problem.horizon() + 1);
  return testing::evaluate_once(problem, inputs, states).total();
}

TEST(SimulatedAnnealing, ReachesTheClosedFormOptimumOfALinearQuadraticProblem) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = make_lq_problem(model, 10);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  const double optimal_cost = cost_of(problem, optimum);

  SaOptions options;
  options.knots = 0;  // one knot per step: the optimum is representable exactly
  options.max_iterations = 40000;
  SimulatedAnnealingSolver solver(problem, options);
  Solution solution;
  solution.resize(6, 3, 10);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
  // Documented tolerance: within 1 % of the optimal cost from a cold (zero) start.
  EXPECT_LE(solution.cost, optimal_cost * 1.01) << "optimum " << optimal_cost;
  RecordProperty("relative_gap", std::to_string(solution.cost / optimal_cost - 1.0));
  EXPECT_GE(solution.cost, optimal_cost * (1 - 1e-9));
  EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
}

// A short anneal (600 proposals) ends well above the LQ optimum; the polish (projected L-BFGS on the
// exact gradient) from its best plan closes most of that gap, and never raises the cost.
TEST(SimulatedAnnealing, ThePolishBringsAShortAnnealClosToTheClosedFormOptimum) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = make_lq_problem(model, 10);
  const double optimal_cost = cost_of(problem, testing::double_integrator_optimum(problem, model));
  SaOptions options;
  options.knots = 0;
  options.max_iterations = 600;
  double gap[2];
  for (const int polished : {0, 1}) {
    options.polish_share = polished ? 0.3 : 0.0;
    SimulatedAnnealingSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 10);
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
    EXPECT_TRUE(problem.is_feasible(solution.inputs));
    gap[polished] = solution.cost / optimal_cost - 1.0;
    std::printf("[          ] %s: %.3e above the optimum (%s)\n", polished ? "polished" : "annealed only", gap[polished],
                summary.reason);
  }
  EXPECT_GT(gap[0], 1e-2);            // the short anneal alone is not there
  EXPECT_LT(gap[1], 1e-3);            // the polish is
  EXPECT_GE(gap[1], -1e-9);
}

// A model's steps without its Jacobians: the exact polish cannot run, the knot polish can.
class StepsOnly final : public PredictionModel {
 public:
  explicit StepsOnly(const PredictionModel& model) : model_(model) {}
  int state_size() const noexcept override { return model_.state_size(); }
  int input_size() const noexcept override { return model_.input_size(); }
  std::unique_ptr<PredictionData> create_data() const override { return model_.create_data(); }
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
            Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override {
    return model_.step(data, x, u, dt, x_next, stage_wear);
  }

 private:
  const PredictionModel& model_;
};

// Without Jacobians, the polish runs L-BFGS over the knot offsets on forward differences. With one
// knot per step the offsets span every plan, so it too closes most of a short anneal's gap to the
// closed-form optimum; without it (knot_polish off) the gap stays.
TEST(SimulatedAnnealing, TheKnotPolishBringsAShortAnnealCloseToTheOptimumWithoutJacobians) {
  const DoubleIntegratorModel model(0.5);
  const StepsOnly steps_only(model);
  const OcpProblem problem = make_lq_problem(steps_only, 10);
  const double optimal_cost = cost_of(problem, testing::double_integrator_optimum(problem, model));
  SaOptions options;
  options.knots = 0;
  options.max_iterations = 600;
  options.polish_share = 0.3;
  double gap[2];
  for (const int knot_polish : {0, 1}) {
    options.knot_polish = knot_polish == 1;
    SimulatedAnnealingSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 10);
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    EXPECT_STREQ(summary.reason, knot_polish ? "completed the annealing schedule and the knot polish"
                                             : "completed the annealing schedule");
    EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
    EXPECT_NEAR(cost_of(problem, solution.inputs), solution.cost, 1e-9 * solution.cost);
    EXPECT_TRUE(problem.is_feasible(solution.inputs));
    gap[knot_polish] = solution.cost / optimal_cost - 1.0;
    std::printf("[          ] %s: %.3e above the optimum\n", knot_polish ? "knot-polished" : "annealed only",
                gap[knot_polish]);
  }
  EXPECT_GT(gap[0], 1e-2);
  EXPECT_LT(gap[1], 1e-3);
  EXPECT_GE(gap[1], -1e-9);
}

// With few knots the offsets span a subspace; the knot polish reaches that subspace's optimum, which
// a long anneal over the same knots approaches from above, and it never ends above the anneal's best.
TEST(SimulatedAnnealing, TheKnotPolishReachesTheBestPlanOfItsKnotsAndNeverRaisesTheCost) {
  const DoubleIntegratorModel model(0.5);
  const StepsOnly steps_only(model);
  const OcpProblem problem = make_lq_problem(steps_only, 12);
  SaOptions options;
  options.knots = 3;
  options.polish_share = 0.3;
  options.max_iterations = 40000;  // a long anneal over 9 offsets: near their optimum
  options.knot_polish = false;
  Solution annealed;
  annealed.resize(6, 3, 12);
  SolveSummary summary;
  SimulatedAnnealingSolver long_anneal(problem, options);
  ASSERT_EQ(long_anneal.solve(problem, {}, far_deadline(), &annealed, &summary), SolveStatus::kConverged);
  options.max_iterations = 60;
  for (const bool knot_polish : {false, true}) {
    options.knot_polish = knot_polish;
    SimulatedAnnealingSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 12);
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    std::printf("[          ] 60 proposals%s: %.6e (40000 proposals: %.6e)\n", knot_polish ? " + knot polish" : "",
                solution.cost, annealed.cost);
    if (knot_polish) {
      EXPECT_LE(solution.cost, annealed.cost * (1.0 + 1e-6));
      EXPECT_LE(solution.cost, summary.initial_cost);
    } else {
      EXPECT_GT(solution.cost, annealed.cost * (1.0 + 1e-3));  // the short anneal alone is not there
    }
  }
}

// Batched proposals (threads = 2): the worker rolls out its proposal on scratch of its own. On the
// swerve prediction (a model with scratch), the answer is the same bit for bit on every run, and on
// a problem over another model instance of the same vehicle, for which the solver makes its
// threads' scratch anew: no data race, and no scratch of the wrong model, reaches the result.
TEST(SimulatedAnnealing, BatchedProposalsOnAWorkerGiveTheSameAnswerOnEveryRunAndOnAnotherModelInstance) {
  testing::SwerveTestProblem shape(testing::SwerveScene::kTurn, 20);
  testing::SwerveTestProblem other_model(testing::SwerveScene::kTurn, 20);
  ASSERT_NE(&shape.problem.model(), &other_model.problem.model());
  SaOptions options;
  options.threads = 2;
  options.max_iterations = 150;
  Eigen::MatrixXd answers[3];
  long rollouts[3] = {0, 0, 0};
  for (int run = 0; run < 3; ++run) {
    SimulatedAnnealingSolver solver(shape.problem, options);
    const OcpProblem& problem = run < 2 ? shape.problem : other_model.problem;
    Solution solution;
    solution.resize(problem.state_size(), problem.input_size(), problem.horizon());
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    EXPECT_TRUE(problem.is_feasible(solution.inputs));
    EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
    answers[run] = solution.inputs;
    rollouts[run] = summary.rollouts;
  }
  EXPECT_EQ(answers[1], answers[0]) << "two runs on the worker differ";
  EXPECT_EQ(answers[2], answers[0]) << "the answer on another model instance differs";
  EXPECT_EQ(rollouts[1], rollouts[0]);
  EXPECT_EQ(rollouts[2], rollouts[0]);
  // Two proposals per step (some undone by the projection), so well over one rollout per step.
  EXPECT_GT(rollouts[0], 150 + 100);
}

// With workers the exact polish's gradient is linearised in shares of stages, one per thread. The
// answer is the same bit for bit on a problem over another model instance (the threads' scratch
// made anew for it), and the polish does lower the cost.
TEST(SimulatedAnnealing, ThePolishsGradientInSharesOnWorkersGivesTheSameAnswerOnAnotherModelInstance) {
  testing::SwerveTestProblem shape(testing::SwerveScene::kTurn, 20);
  testing::SwerveTestProblem other_model(testing::SwerveScene::kTurn, 20);
  SaOptions options;
  options.threads = 2;
  options.max_iterations = 60;
  options.polish_share = 0.3;
  Eigen::MatrixXd answers[2];
  double costs[2] = {0.0, 0.0};
  for (int run = 0; run < 2; ++run) {
    SimulatedAnnealingSolver solver(shape.problem, options);
    const OcpProblem& problem = run == 0 ? shape.problem : other_model.problem;
    Solution solution;
    solution.resize(problem.state_size(), problem.input_size(), problem.horizon());
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    EXPECT_STREQ(summary.reason, "completed the annealing schedule and the polish");
    EXPECT_TRUE(problem.is_feasible(solution.inputs));
    EXPECT_NEAR(summary.cost.total(), solution.cost, 1e-9 * solution.cost);
    answers[run] = solution.inputs;
    costs[run] = solution.cost;
  }
  EXPECT_EQ(answers[1], answers[0]) << "the shares on another model instance differ";
  EXPECT_EQ(costs[1], costs[0]);
  options.polish_share = 0.0;
  SimulatedAnnealingSolver annealer(shape.problem, options);
  Solution annealed;
  annealed.resize(shape.problem.state_size(), shape.problem.input_size(), shape.problem.horizon());
  ASSERT_EQ(annealer.solve(shape.problem, {}, far_deadline(), &annealed, nullptr), SolveStatus::kConverged);
  EXPECT_LT(costs[0], annealed.cost);
}

// Two threads, the polish and a work clock the prediction model charges from both threads (the
// configuration `make tsan` exists for): every solve ends by its deadline with a feasible plan.
TEST(SimulatedAnnealing, TwoThreadsWithThePolishOnAChargedWorkClockEndByTheDeadline) {
  testing::SwerveTestProblem shape(testing::SwerveScene::kTurn, 20);
  const WorkClock clock(2e-6, 1e-7);
  shape.model.charge_work_to(&clock);
  SaOptions options;
  options.threads = 2;
  options.polish_share = 0.3;
  options.max_iterations = 100000;
  SimulatedAnnealingSolver solver(shape.problem, options);
  Solution solution;
  solution.resize(shape.problem.state_size(), shape.problem.input_size(), shape.problem.horizon());
  for (int solve = 0; solve < 3; ++solve) {
    SolveSummary summary;
    const TimePoint start = clock.now();
    EXPECT_EQ(solver.solve(shape.problem, {}, Deadline(start + 5ms, clock), &solution, &summary),
              SolveStatus::kBudgetExhausted);
    EXPECT_LE(clock.now() - start, 5ms) << "solve " << solve;
    EXPECT_GT(summary.rollouts, 10) << "solve " << solve;
    EXPECT_TRUE(shape.problem.is_feasible(solution.inputs)) << "solve " << solve;
  }
  shape.model.charge_work_to(nullptr);
}

// The cheapest of two proposals per step anneals further per step than one proposal: over five
// seeds of the same schedule, two threads end lower on average (and threads = 1 is the solver's
// single-proposal path, whose results the other tests pin).
TEST(SimulatedAnnealing, TwoProposalsPerStepEndLowerThanOneOnAverageOverFiveSeeds) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = make_lq_problem(model, 10);
  double total[2] = {0.0, 0.0};
  for (const int threads : {1, 2}) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      SaOptions options;
      options.knots = 0;
      options.max_iterations = 400;
      options.seed = seed;
      options.threads = threads;
      SimulatedAnnealingSolver solver(problem, options);
      Solution solution;
      solution.resize(6, 3, 10);
      SolveSummary summary;
      ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
      total[threads - 1] += solution.cost;
    }
  }
  std::printf("[          ] mean cost over 5 seeds: one proposal per step %.4f, two %.4f\n", total[0] / 5,
              total[1] / 5);
  EXPECT_LT(total[1], total[0]);
}

// Options of the polish deadline tests: only the clock stops the solve, and the polish has 70 % of
// it, with the knot polish where the exact one does not fit.
SaOptions clock_bound_polish_options() {
  SaOptions options;
  options.max_iterations = 100000000;
  options.polish_share = 0.7;
  options.knot_polish = true;
  return options;
}

// The polish keeps the deadline. On a clock charging 2 us per model step and 40 or 80 us per step
// with Jacobians (a gradient of 40 steps: 1.6 or 3.2 ms, i.e. 20 or 40 rollouts), 5 ms solves with
// 3.5 ms for the polish return by their deadline: the first gradient's time is foreseen from one
// timed stage, and with its 1.5x allowance only the cheaper gradient fits; with the dearer one the
// knot polish runs instead (18 offsets at <= 80 us a rollout).
TEST(SimulatedAnnealing, ThePolishHonoursTheDeadline) {
  const DoubleIntegratorModel model;
  for (const double jacobian_cost : {40e-6, 80e-6}) {
    SCOPED_TRACE(::testing::Message() << "jacobian step " << jacobian_cost * 1e6 << " us");
    testing::WorkClock clock;
    const testing::ClockedModel clocked(model, &clock, 2e-6, jacobian_cost);
    const OcpProblem problem = make_lq_problem(clocked, 40);
    SimulatedAnnealingSolver solver(problem, clock_bound_polish_options());
    Solution solution;
    solution.resize(6, 3, 40);
    for (int solve = 0; solve < 3; ++solve) {
      SolveSummary summary;
      const TimePoint start = clock.now();
      const long gradients_before = clocked.jacobian_steps();
      const SolveStatus status = solver.solve(problem, {}, Deadline(start + 5ms, clock), &solution, &summary);
      EXPECT_EQ(status, SolveStatus::kBudgetExhausted);
      EXPECT_LE(clock.now() - start, 5ms) << "solve " << solve;
      if (jacobian_cost < 50e-6) {
        EXPECT_GT(clocked.jacobian_steps(), gradients_before + 1) << "solve " << solve << ": no polish";
        EXPECT_STREQ(summary.reason, "annealed and polished until the deadline");
      } else {
        EXPECT_LE(clocked.jacobian_steps(), 1) << "solve " << solve << ": a polish that could not fit";
        // In its place the knot polish, on forward differences (no Jacobian), in the same window.
        EXPECT_STREQ(summary.reason, "annealed and polished over the knots until the deadline");
      }
    }
  }
}

// A gradient's cost depends on the state (the prediction's slow-motion substeps and Newton splits),
// so the polish may start one it cannot finish: it gives up between stages instead of returning
// late. The solver learns 40 us per Jacobian step, then meets 400 us (a 16 ms gradient) in a 5 ms solve.
TEST(SimulatedAnnealing, ThePolishGivesUpAGradientThatTurnsOutSlowerThanForeseen) {
  const DoubleIntegratorModel model;
  testing::WorkClock clock;
  const testing::ClockedModel cheap(model, &clock, 2e-6, 40e-6);
  const testing::ClockedModel dear(model, &clock, 2e-6, 400e-6);
  const OcpProblem cheap_problem = make_lq_problem(cheap, 40);
  const std::unique_ptr<OcpProblem> dear_problem = testing::problem_on(dear, cheap_problem);
  SimulatedAnnealingSolver solver(cheap_problem, clock_bound_polish_options());
  Solution solution;
  solution.resize(6, 3, 40);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(cheap_problem, {}, Deadline(clock.now() + 5ms, clock), &solution, &summary),
            SolveStatus::kBudgetExhausted);
  ASSERT_STREQ(summary.reason, "annealed and polished until the deadline");
  const TimePoint start = clock.now();
  EXPECT_EQ(solver.solve(*dear_problem, {}, Deadline(start + 5ms, clock), &solution, &summary),
            SolveStatus::kBudgetExhausted);
  EXPECT_LE(clock.now() - start, 5ms);
  EXPECT_GT(dear.jacobian_steps(), 0);  // it did start one
  EXPECT_TRUE(solution.valid);
}

TEST(SimulatedAnnealing, KeepsEveryInputInsideItsBounds) {
  const DoubleIntegratorModel model;
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d::Constant(-0.3);
  bounds.upper = Eigen::Vector3d::Constant(0.2);
  bounds.max_step = Eigen::Vector3d::Constant(0.05);
  const OcpProblem problem = make_lq_problem(model, 12, bounds);
  SaOptions options;
  options.max_iterations = 3000;
  SimulatedAnnealingSolver solver(problem, options);
  Solution solution;
  solution.resize(6, 3, 12);
  ASSERT_TRUE(has_solution(solver.solve(problem, {}, far_deadline(), &solution, nullptr)));
  EXPECT_TRUE(problem.is_feasible(solution.inputs));
}

TEST(SimulatedAnnealing, IsNeverWorseThanItsBestInitialGuess) {
  const DoubleIntegratorModel model;
  const OcpProblem problem = make_lq_problem(model, 10);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  Eigen::MatrixXd bad = Eigen::MatrixXd::Constant(3, 10, 3.0);
  InitialGuesses guesses;
  guesses.add(&bad);
  guesses.add(&optimum);
  SaOptions options;
  options.max_iterations = 200;
  SimulatedAnnealingSolver solver(problem, options);
  Solution solution;
  solution.resize(6, 3, 10);
  ASSERT_TRUE(has_solution(solver.solve(problem, guesses, far_deadline(), &solution, nullptr)));
  EXPECT_LE(solution.cost, cost_of(problem, optimum) * (1 + 1e-12));
}

TEST(SimulatedAnnealing, IdenticalSeedsGiveIdenticalSolutions) {
  const DoubleIntegratorModel model(0.2);
  const OcpProblem problem = make_lq_problem(model, 15);
  SaOptions options;
  options.max_iterations = 2000;
  options.seed = 42;
  Solution a, b, c;
  a.resize(6, 3, 15);
  b.resize(6, 3, 15);
  c.resize(6, 3, 15);
  SimulatedAnnealingSolver first(problem, options), second(problem, options);
  first.solve(problem, {}, far_deadline(), &a, nullptr);
  second.solve(problem, {}, far_deadline(), &b, nullptr);
  EXPECT_EQ(a.inputs, b.inputs);
  options.seed = 43;
  SimulatedAnnealingSolver third(problem, options);
  third.solve(problem, {}, far_deadline(), &c, nullptr);
  EXPECT_NE(a.inputs, c.inputs);
}

// A longer run does not replay a shorter one: the schedule cools on the share of the budget used,
// so the same seed at a larger budget takes different moves from the first iteration on, and no
// ordering of the two best costs is guaranteed. What is guaranteed for any budget: the plan returned
// is the best one seen, so its cost never exceeds the starting cost, and it is the plan's own cost.
TEST(SimulatedAnnealing, ReturnsItsBestPlanWhichNeverCostsMoreThanTheStartAtAnyBudget) {
  const DoubleIntegratorModel model(0.2);
  const OcpProblem problem = make_lq_problem(model, 20);
  for (const int iterations : {1, 10, 200, 2000}) {
    SCOPED_TRACE(iterations);
    SaOptions options;
    options.max_iterations = iterations;
    SimulatedAnnealingSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 20);
    SolveSummary summary;
    ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, &summary), SolveStatus::kConverged);
    EXPECT_LE(solution.cost, summary.initial_cost);
    // Tolerance: the same rollout evaluated twice; relative 1e-12 allows only a different
    // summation order.
    EXPECT_NEAR(cost_of(problem, solution.inputs), solution.cost, 1e-12 * solution.cost);
  }
}

// Not a theorem (see above) but what the budget is for: ten times the iterations ends lower for
// each of these seeds. Iteration-capped with a far deadline, so the schedule ignores the clock and
// the result is repeatable: this checks that a bigger budget is used, not machine speed.
TEST(SimulatedAnnealing, TenTimesTheIterationsEndsLowerOnEachOfFiveSeeds) {
  const DoubleIntegratorModel model(0.2);
  const OcpProblem problem = make_lq_problem(model, 20);
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE(seed);
    double cost[2] = {0.0, 0.0};
    for (int run = 0; run < 2; ++run) {
      SaOptions options;
      options.seed = seed;
      options.max_iterations = run == 0 ? 500 : 5000;
      SimulatedAnnealingSolver solver(problem, options);
      Solution solution;
      solution.resize(6, 3, 20);
      ASSERT_EQ(solver.solve(problem, {}, far_deadline(), &solution, nullptr), SolveStatus::kConverged);
      cost[run] = solution.cost;
    }
    EXPECT_LT(cost[1], cost[0]);
  }
}

TEST(SimulatedAnnealing, HonoursTheDeadline) {
  // On a clock that advances 2 us per model step (80 us per full rollout of 40 steps), the solve
  // must return by its 3 ms deadline: the loop keeps room for one more proposal and one rollout of
  // slack, and the answer's cost comes from its own rollout. Deterministic: no wall clock.
  const DoubleIntegratorModel model;
  testing::WorkClock clock;
  const testing::ClockedModel clocked(model, &clock, 2e-6, 2e-6);
  const OcpProblem problem = make_lq_problem(clocked, 40);
  SaOptions options;
  options.max_iterations = 100000000;
  SimulatedAnnealingSolver solver(problem, options);
  Solution solution;
  solution.resize(6, 3, 40);
  SolveSummary summary;
  const TimePoint start = clock.now();
  const SolveStatus status = solver.solve(problem, {}, Deadline(start + 3ms, clock), &solution, &summary);
  const Duration elapsed = clock.now() - start;
  EXPECT_EQ(status, SolveStatus::kBudgetExhausted);
  EXPECT_TRUE(solution.valid);
  EXPECT_LE(elapsed, 3ms);
  // ...and uses its time: it stops within one full rollout of slack and one proposal (160 us) of it.
  EXPECT_GE(elapsed, 3ms - 160us) << summary.iterations << " iterations";
  // The summary's solve time is read off the same clock.
  EXPECT_DOUBLE_EQ(summary.solve_time_s, to_seconds(elapsed));
}

// A model whose step costs more on the clock once the body moves faster than `speed`: the swerve
// prediction's slow-motion substeps make some plans' rollouts ~10x dearer than others, so the
// start's rollout is no measure of the answer's.
class DearAboveSpeedModel final : public PredictionModel {
 public:
  DearAboveSpeedModel(const PredictionModel& model, testing::WorkClock* clock, double speed, double cheap_s,
                      double dear_s)
      : model_(model), clock_(clock), speed_(speed), cheap_(to_duration(cheap_s)), dear_(to_duration(dear_s)) {}
  int state_size() const noexcept override { return model_.state_size(); }
  int input_size() const noexcept override { return model_.input_size(); }
  std::unique_ptr<PredictionData> create_data() const override { return model_.create_data(); }
  bool has_jacobians() const noexcept override { return model_.has_jacobians(); }
  bool step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
            Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override {
    clock_->advance(x.segment<3>(3).norm() > speed_ ? dear_ : cheap_);
    return model_.step(data, x, u, dt, x_next, stage_wear);
  }
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                      double dt, Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                      Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                      Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override {
    clock_->advance(4 * (x.segment<3>(3).norm() > speed_ ? dear_ : cheap_));
    return model_.step_jacobians(data, x, u, dt, x_next, a, b, stage_wear, wear_gradient);
  }

 private:
  const PredictionModel& model_;
  testing::WorkClock* clock_;
  double speed_;
  Duration cheap_, dear_;
};

TEST(SimulatedAnnealing, ReturnsByTheDeadlineWhenItsAnswerRollsOutDearerThanItsStart) {
  // From rest, the start plan (zero inputs) stays still: 2 us a step. The answer runs at ~1 m/s,
  // where a step costs 40 us: 1.6 ms a rollout. Rolling the answer out again to report its cost,
  // with room kept only for the start's rollout, ended up to 1.5 ms late (the swerve vehicle's
  // final stop, where the slow-motion substeps make the plans dear); the answer's cost now comes
  // from its own rollout. With and without the polish.
  const DoubleIntegratorModel model;
  for (const double polish_share : {0.0, 0.3}) {
    SCOPED_TRACE(polish_share);
    testing::WorkClock clock;
    const DearAboveSpeedModel priced(model, &clock, 0.5, 2e-6, 40e-6);
    const OcpProblem problem = make_lq_problem(priced, 40);
    SaOptions options;
    options.max_iterations = 100000000;
    options.polish_share = polish_share;
    SimulatedAnnealingSolver solver(problem, options);
    Solution solution;
    solution.resize(6, 3, 40);
    SolveSummary summary;
    for (int solve = 0; solve < 3; ++solve) {
      const TimePoint start = clock.now();
      solver.solve(problem, {}, Deadline(start + 20ms, clock), &solution, &summary);
      EXPECT_LE(to_seconds(clock.now() - start), 0.020) << "solve " << solve;
      EXPECT_TRUE(solution.valid);
      // The reported cost is the answer's.
      Eigen::MatrixXd states(6, 41);
      EXPECT_NEAR(summary.cost.total(), testing::evaluate_once(problem, solution.inputs, states).total(), 1e-9 * summary.cost.total());
      ASSERT_GT(solution.states.col(40).segment<3>(3).norm(), 0.5) << "the answer must be a dear plan";
    }
  }
}

TEST(SimulatedAnnealing, ReturnsByTheDeadlineWhenItsInitialGuessesRollOutDear) {
  // Two guesses accelerate at 1 m/s^2 from rest: past 0.5 m/s a step costs 40 us, so each rollout
  // costs ~1.4 ms. Rolling both out and then the chosen one again ended at ~4.3 ms, past a 2.5 ms
  // deadline, with no proposal made (the Jetson target's misses near standstill). Now the second
  // guess waits for room and the start's own rollout is reused.
  const DoubleIntegratorModel model;
  testing::WorkClock clock;
  const DearAboveSpeedModel priced(model, &clock, 0.5, 2e-6, 40e-6);
  const OcpProblem problem = make_lq_problem(priced, 40);
  const Eigen::MatrixXd accelerate = Eigen::Vector3d(1.0, 0.0, 0.0).replicate(1, 40);
  const Eigen::MatrixXd accelerate_sideways = Eigen::Vector3d(1.0, 0.2, 0.0).replicate(1, 40);
  InitialGuesses guesses;
  guesses.add(&accelerate);
  guesses.add(&accelerate_sideways);
  SimulatedAnnealingSolver solver(problem, SaOptions{});
  Solution solution;
  solution.resize(6, 3, 40);
  SolveSummary summary;
  const TimePoint start = clock.now();
  const SolveStatus status = solver.solve(problem, guesses, Deadline(start + 2500us, clock), &solution, &summary);
  EXPECT_LE(clock.now() - start, 2500us);
  EXPECT_EQ(status, SolveStatus::kBudgetExhausted);
  EXPECT_TRUE(solution.valid);
  EXPECT_EQ(solution.inputs, accelerate) << "the one guess there was time for";
  Eigen::MatrixXd states(6, 41);
  EXPECT_NEAR(summary.cost.total(), testing::evaluate_once(problem, solution.inputs, states).total(), 1e-9 * summary.cost.total());
}

TEST(SimulatedAnnealing, WarmStartReachesATargetCostInFewerIterationsThanCold) {
  const DoubleIntegratorModel model(0.2);
  OcpProblem problem = make_lq_problem(model, 15);
  SaOptions options;
  options.max_iterations = 20000;
  SimulatedAnnealingSolver solver(problem, options);
  Solution previous;
  previous.resize(6, 3, 15);
  solver.solve(problem, {}, far_deadline(), &previous, nullptr);

  // Next cycle: the state advanced by the first input, the reference window moved on by one.
  Eigen::VectorXd x1(6);
  double wear = 0.0;
  testing::step_once(model, problem.initial_state(), previous.inputs.col(0), problem.dt(), x1, &wear);
  problem.set_initial_state(x1);
  problem.set_previous_input(previous.inputs.col(0));
  for (int k = 1; k <= 15; ++k) problem.set_reference(k, {0.1 * (k + 1), 0.05 * (k + 1), 0.01 * (k + 1)}, {0, 0, 0});
  previous.shift();
  const double target = cost_of(problem, testing::double_integrator_optimum(problem, model)) * 1.05;

  auto iterations_to_reach = [&](const InitialGuesses& guesses) {
    for (int budget : {1, 10, 30, 100, 300, 1000, 3000, 10000, 30000}) {
      SaOptions run = options;
      run.max_iterations = budget;
      SimulatedAnnealingSolver fresh(problem, run);
      Solution solution;
      solution.resize(6, 3, 15);
      fresh.solve(problem, guesses, far_deadline(), &solution, nullptr);
      if (solution.cost <= target) return budget;
    }
    return std::numeric_limits<int>::max();
  };
  InitialGuesses warm;
  warm.add(&previous.inputs);
  const int warm_iterations = iterations_to_reach(warm);
  const int cold_iterations = iterations_to_reach({});
  EXPECT_LT(warm_iterations, cold_iterations);
}

class FailingModel final : public PredictionModel {
 public:
  int state_size() const noexcept override { return 6; }
  int input_size() const noexcept override { return 2; }
  bool step(PredictionData&, const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&, double,
            Eigen::Ref<Eigen::VectorXd> x_next, double*) const noexcept override {
    x_next.setConstant(std::numeric_limits<double>::quiet_NaN());
    return false;
  }
};

TEST(SimulatedAnnealing, ReportsStatusesInsteadOfFailingSilently) {
  const FailingModel failing;
  const OcpProblem broken(failing, 5, 0.1, {}, {});
  SimulatedAnnealingSolver solver(broken, {});
  Solution solution;
  solution.resize(6, 2, 5);
  SolveSummary summary;
  EXPECT_EQ(solver.solve(broken, {}, far_deadline(), &solution, &summary), SolveStatus::kNumericalError);
  EXPECT_FALSE(solution.valid);
  EXPECT_STREQ(to_string(summary.status), "numerical_error");

  const DoubleIntegratorModel model;
  const OcpProblem problem = make_lq_problem(model, 5);
  SimulatedAnnealingSolver good(problem, {});
  Solution wrong_size;
  wrong_size.resize(6, 3, 4);
  EXPECT_EQ(good.solve(problem, {}, far_deadline(), &wrong_size, nullptr), SolveStatus::kInvalidInput);
  Solution right;
  right.resize(6, 3, 5);
  EXPECT_EQ(good.solve(problem, {}, SolverClock::now() - 1ms, &right, nullptr), SolveStatus::kInvalidInput);
  Eigen::MatrixXd nan_guess = Eigen::MatrixXd::Constant(3, 5, std::numeric_limits<double>::quiet_NaN());
  InitialGuesses guesses;
  guesses.add(&nan_guess);
  EXPECT_TRUE(has_solution(good.solve(problem, guesses, far_deadline(), &right, nullptr)));  // NaN guess skipped
}

TEST(SaOptions, EveryFieldIsValidated) {
  const auto invalid = [](auto mutate) {
    SaOptions options;
    mutate(options);
    EXPECT_THROW(options.validate(), ConfigError);
  };
  invalid([](SaOptions& o) { o.knots = -1; });
  invalid([](SaOptions& o) { o.max_iterations = 0; });
  invalid([](SaOptions& o) { o.initial_acceptance = 1.0; });
  invalid([](SaOptions& o) { o.final_temperature_ratio = 0.0; });
  invalid([](SaOptions& o) { o.step_fraction = 0.0; });
  invalid([](SaOptions& o) { o.target_acceptance = 0.0; });
  invalid([](SaOptions& o) { o.adapt_interval = 0; });
  invalid([](SaOptions& o) { o.reheat_interval = -1; });
  invalid([](SaOptions& o) { o.probability_one_group = 0.8; });
  invalid([](SaOptions& o) { o.polish_share = 1.0; });
  invalid([](SaOptions& o) { o.polish_share = -0.1; });
  invalid([](SaOptions& o) { o.polish_iterations = -1; });
  invalid([](SaOptions& o) { o.threads = 0; });
  invalid([](SaOptions& o) { o.threads = 17; });
  EXPECT_NO_THROW(SaOptions{}.validate());
}

}  // namespace
}  // namespace swerve
