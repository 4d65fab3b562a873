// The start every backend shares (StartPlan): the cheapest usable guess with its own rollout, zero
// inputs when none is usable, and only as many guesses rolled out as the deadline leaves room for.
#include <gtest/gtest.h>

#include <chrono>
#include <limits>

#include "support/fake_clocks.hpp"
#include "support/linear_models.hpp"
#include "swerve/ocp/solver.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

using testing::DoubleIntegratorModel;
using testing::make_lq_problem;
using namespace std::chrono_literals;

Deadline far_deadline() { return SolverClock::now() + 60s; }

TEST(StartPlan, ChoosesTheCheapestUsableGuessWithItsOwnRolloutAndCost) {
  const DoubleIntegratorModel model(0.5);
  const OcpProblem problem = make_lq_problem(model, 10);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  const Eigen::MatrixXd wrong_size = Eigen::MatrixXd::Zero(3, 9);
  Eigen::MatrixXd not_finite = optimum;
  not_finite(1, 4) = std::numeric_limits<double>::quiet_NaN();
  const Eigen::MatrixXd poor = Eigen::MatrixXd::Constant(3, 10, 0.7);
  InitialGuesses guesses;
  guesses.add(&wrong_size);
  guesses.add(&not_finite);
  guesses.add(&poor);
  guesses.add(&optimum);

  StartPlan start(problem);
  const double cost = start.choose(problem, guesses, far_deadline());
  EXPECT_EQ(start.inputs(), optimum);
  EXPECT_EQ(start.rollouts(), 2) << "the unusable guesses are not rolled out";
  EXPECT_EQ(start.skipped(), 0);
  // Its states, cost and split are those of a fresh evaluation of the same inputs.
  Eigen::MatrixXd states(6, 11);
  const CostBreakdown fresh = testing::evaluate_once(problem, optimum, states);
  EXPECT_EQ(start.states(), states);
  EXPECT_DOUBLE_EQ(cost, fresh.total());
  EXPECT_DOUBLE_EQ(start.cost(), fresh.total());
  EXPECT_DOUBLE_EQ(start.breakdown(problem).wear, fresh.wear);
  EXPECT_DOUBLE_EQ(start.breakdown(problem).total(), fresh.total());
  EXPECT_GT(fresh.wear, 0.0);
}

TEST(StartPlan, StartsFromZeroInputsProjectedOntoTheBoundsWhenNoGuessIsUsable) {
  const DoubleIntegratorModel model;
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d(0.2, -1.0, -1.0);  // zero is outside the first input's box
  bounds.upper = Eigen::Vector3d(1.0, 1.0, 1.0);
  bounds.max_step = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  const OcpProblem problem = make_lq_problem(model, 8, bounds);
  StartPlan start(problem);
  const double cost = start.choose(problem, {}, far_deadline());
  EXPECT_TRUE(std::isfinite(cost));
  EXPECT_EQ(start.rollouts(), 1);
  EXPECT_TRUE((start.inputs().row(0).array() == 0.2).all());
  EXPECT_TRUE((start.inputs().bottomRows(2).array() == 0.0).all());
}

TEST(StartPlan, RollsOutAFurtherGuessOnlyWhileTheDeadlineLeavesRoomForItAndOneMore) {
  // Each step costs 10 us on the work clock, so a rollout over 10 steps costs 100 us. The third
  // guess is the cheapest, but once two rollouts are done (200 us) a third and one more of slack
  // would end at 400 us, past a 350 us deadline.
  const DoubleIntegratorModel model(0.5);
  testing::WorkClock clock;
  const testing::ClockedModel clocked(model, &clock, 10e-6, 0.0);
  const OcpProblem problem = make_lq_problem(clocked, 10);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  const Eigen::MatrixXd poor = Eigen::MatrixXd::Zero(3, 10);
  const Eigen::MatrixXd poorer = Eigen::MatrixXd::Constant(3, 10, -0.5);  // away from the reference
  InitialGuesses guesses;
  guesses.add(&poorer);
  guesses.add(&poor);
  guesses.add(&optimum);

  StartPlan start(problem);
  start.choose(problem, guesses, Deadline(clock.now() + 350us, clock));
  EXPECT_EQ(start.rollouts(), 2);
  EXPECT_EQ(start.skipped(), 1);
  EXPECT_EQ(start.inputs(), poor) << "the cheaper of the two rolled out";
  EXPECT_EQ(start.longest_rollout(), 100us);

  // With time for all three, the cheapest is chosen.
  start.choose(problem, guesses, Deadline(clock.now() + 1ms, clock));
  EXPECT_EQ(start.rollouts(), 3);
  EXPECT_EQ(start.skipped(), 0);
  EXPECT_EQ(start.inputs(), optimum);

  // The first usable guess is rolled out even when the deadline has no room for it: a backend
  // always needs one plan to return.
  start.choose(problem, guesses, Deadline(clock.now() + 50us, clock));
  EXPECT_EQ(start.rollouts(), 1);
  EXPECT_EQ(start.skipped(), 2);
  EXPECT_EQ(start.inputs(), poorer);
}

}  // namespace
}  // namespace swerve
