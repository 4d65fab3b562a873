// OcpProblem: the exact cost of a hand-computed case, projection onto bounds, incremental
// rollouts, and validation of every field.
#include "swerve/ocp/ocp_problem.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "support/two_threads.hpp"
#include "swerve/core/config_error.hpp"
#include "support/config_errors.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

using testing::DoubleIntegratorModel;

// |u| <= 1 on every input, and at most `max_step` of change per step.
InputBounds unit_box_with_step(double max_step) {
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d::Constant(-1.0);
  bounds.upper = Eigen::Vector3d::Constant(1.0);
  bounds.max_step = Eigen::Vector3d::Constant(max_step);
  return bounds;
}

CostWeights hand_weights() {
  CostWeights w;
  w.pose = {10.0, 10.0, 5.0};
  w.terminal_scale = 10.0;
  w.effort = Eigen::Vector3d::Constant(1.0);
  w.rate = Eigen::Vector3d::Constant(2.0);
  w.wear = 0.5;
  return w;
}

TEST(OcpProblem, CostOfAHandComputedCaseIsExact) {
  // dt = 1, x0 = 0, u0 = (1, 0, 0), u1 = 0, reference at the origin:
  //   x1 = 0.5 (v 1), x2 = 1.5: tracking 10 * 0.25 + 10 * 10 * 2.25 = 227.5
  //   effort 1 * 1 = 1; rate 2 * (1 - 0)^2 + 2 * (0 - 1)^2 = 4; wear 0.5 * (1 * 1 * 1) = 0.5
  const DoubleIntegratorModel model(1.0);
  const OcpProblem problem(model, 2, 1.0, hand_weights(), {});
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 2);
  inputs(0, 0) = 1.0;
  Eigen::MatrixXd states(6, 3);
  const CostBreakdown parts = testing::evaluate_once(problem, inputs, states);
  EXPECT_DOUBLE_EQ(parts.tracking, 227.5);
  EXPECT_DOUBLE_EQ(parts.effort, 1.0);
  EXPECT_DOUBLE_EQ(parts.rate, 4.0);
  EXPECT_DOUBLE_EQ(parts.wear, 0.5);
  EXPECT_DOUBLE_EQ(states(0, 2), 1.5);
  Eigen::VectorXd stage(2);
  EXPECT_DOUBLE_EQ(testing::rollout_once(problem, inputs, 0, states, stage), 233.0);
}

TEST(OcpProblem, HeadingErrorIsWrapped) {
  const DoubleIntegratorModel model;
  CostWeights w;
  w.pose = {0.0, 0.0, 1.0};
  w.terminal_scale = 1.0;
  OcpProblem problem(model, 1, 1.0, w, {});
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(6);
  x0[2] = 3.1;
  ASSERT_TRUE(problem.set_initial_state(x0));
  ASSERT_TRUE(problem.set_reference(1, {0.0, 0.0, -3.1}, Eigen::Vector3d::Zero()));
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 1), states(6, 2);
  const double error = 2 * 3.14159265358979323846 - 6.2;
  EXPECT_NEAR(testing::evaluate_once(problem, inputs, states).tracking, error * error, 1e-12);
}

TEST(OcpProblem, IncrementalRolloutEqualsFullRollout) {
  const DoubleIntegratorModel model(0.3);
  OcpProblem problem(model, 8, 0.1, hand_weights(), {});
  for (int k = 1; k <= 8; ++k) problem.set_reference(k, {0.1 * k, -0.05 * k, 0.02 * k}, Eigen::Vector3d::Zero());
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Random(3, 8), states(6, 9);
  Eigen::VectorXd stage(8);
  testing::rollout_once(problem, inputs, 0, states, stage);
  inputs.col(5) += Eigen::Vector3d(0.3, -0.2, 0.1);
  const double incremental = testing::rollout_once(problem, inputs, 5, states, stage);
  Eigen::MatrixXd fresh_states(6, 9);
  Eigen::VectorXd fresh_stage(8);
  EXPECT_NEAR(incremental, testing::rollout_once(problem, inputs, 0, fresh_states, fresh_stage), 1e-12);
}

TEST(OcpProblem, ProjectionKeepsBoxAndStepBoundsAndReportsTheFirstChange) {
  const DoubleIntegratorModel model;
  OcpProblem problem(model, 4, 0.1, {}, unit_box_with_step(0.25));
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 4);
  inputs(0, 2) = 5.0;  // out of the box and far beyond one step from 0
  EXPECT_EQ(problem.project(inputs), 2);
  EXPECT_DOUBLE_EQ(inputs(0, 2), 0.25);
  EXPECT_DOUBLE_EQ(inputs(0, 3), 0.0);
  EXPECT_TRUE(problem.is_feasible(inputs));
  EXPECT_EQ(problem.project(inputs), 4);  // already feasible: nothing changes
  inputs(1, 0) = std::numeric_limits<double>::quiet_NaN();
  problem.project(inputs);
  EXPECT_DOUBLE_EQ(inputs(1, 0), 0.0);  // a NaN input is replaced by the previous input
}

TEST(OcpProblem, CostOfAHandComputedCaseIncludesTheTwistTermWithoutTerminalScale) {
  // The hand case above with a twist weight (1, 0, 0): the body velocity is 1 m/s after both
  // steps (u0 = 1 for 1 s, then coasting), against a zero reference twist, so the twist term adds
  // 1 * 1^2 per stage = 2, unscaled at the terminal step: tracking 227.5 + 2 = 229.5.
  const DoubleIntegratorModel model(1.0);
  CostWeights weights = hand_weights();
  weights.twist = {1.0, 0.0, 0.0};
  const OcpProblem problem(model, 2, 1.0, weights, {});
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 2);
  inputs(0, 0) = 1.0;
  Eigen::MatrixXd states(6, 3);
  EXPECT_DOUBLE_EQ(testing::evaluate_once(problem, inputs, states).tracking, 229.5);
}

TEST(OcpProblem, ProjectionKeepsTheStepBoundGoingDownToo) {
  const DoubleIntegratorModel model;
  OcpProblem problem(model, 4, 0.1, {}, unit_box_with_step(0.25));
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 4);
  inputs(1, 1) = -5.0;  // below the box and far beyond one step down from 0
  EXPECT_EQ(problem.project(inputs), 1);
  EXPECT_DOUBLE_EQ(inputs(1, 1), -0.25);
  EXPECT_TRUE(problem.is_feasible(inputs));
  // One step of the bound beyond it is infeasible, on either side of the previous input.
  inputs(1, 2) = -0.25 - 0.25 - 1e-3;
  EXPECT_FALSE(problem.is_feasible(inputs));
  inputs(1, 2) = -0.25 + 0.25 + 1e-3;
  EXPECT_FALSE(problem.is_feasible(inputs));
  inputs(1, 2) = -0.25 + 0.25;
  inputs(1, 3) = 0.0;
  EXPECT_TRUE(problem.is_feasible(inputs));
}

TEST(OcpProblem, IsFeasibleRejectsTheBoxAndTheStepBoundEachOnItsOwn) {
  const DoubleIntegratorModel model;
  InputBounds box_only;  // no step bound: only the box can be broken
  box_only.lower = Eigen::Vector3d::Constant(-1.0);
  box_only.upper = Eigen::Vector3d::Constant(1.0);
  const OcpProblem box_problem(model, 4, 0.1, {}, box_only);
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Constant(3, 4, 1.0);
  EXPECT_TRUE(box_problem.is_feasible(inputs, 0.0));
  inputs(2, 3) = 1.001;
  EXPECT_FALSE(box_problem.is_feasible(inputs, 0.0));
  inputs(2, 3) = -1.001;
  EXPECT_FALSE(box_problem.is_feasible(inputs, 0.0));
  InputBounds step_only;  // no box: only the step bound can be broken (from the previous input 0)
  step_only.max_step = Eigen::Vector3d::Constant(0.25);
  const OcpProblem step_problem(model, 4, 0.1, {}, step_only);
  inputs.setZero();
  inputs(0, 0) = 0.25;
  EXPECT_TRUE(step_problem.is_feasible(inputs, 0.0));
  inputs(0, 0) = 0.251;
  EXPECT_FALSE(step_problem.is_feasible(inputs, 0.0));
}

TEST(OcpProblem, PerCycleSettersRejectBadValuesAndKeepTheOldOnes) {
  const DoubleIntegratorModel model;
  OcpProblem problem(model, 3, 0.1, {}, {});
  Eigen::VectorXd x0 = Eigen::VectorXd::Ones(6);
  ASSERT_TRUE(problem.set_initial_state(x0));
  x0[4] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(problem.set_initial_state(x0));
  EXPECT_FALSE(problem.set_initial_state(Eigen::VectorXd::Ones(5)));
  EXPECT_TRUE(problem.initial_state().isOnes());
  EXPECT_FALSE(problem.set_reference(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
  EXPECT_FALSE(problem.set_reference(4, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()));
  EXPECT_FALSE(problem.set_wear_weight(-1.0));
  EXPECT_FALSE(problem.set_previous_input(Eigen::Vector3d(0, std::nan(""), 0)));
}

// The tracking tube: mu (max(0, |e_xy| - b)^2 + max(0, |e_psi| - c)^2), by hand. dt = 1, x0 = 0,
// u = (1, 0, 1): x1 = (0.5, 0, 0.5 rad), so 0.3 m and 0.4 rad beyond a (0.2 m, 0.1 rad) tube.
TEST(OcpProblem, TheTubeCostsMuTimesTheSquaredExcessAndNothingInside) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w;
  w.pose = Eigen::Vector3d::Zero();
  w.tube_penalty = 100.0;
  OcpProblem problem(model, 1, 1.0, w, {});
  Eigen::MatrixXd inputs(3, 1);
  inputs << 1.0, 0.0, 1.0;
  Eigen::MatrixXd states(6, 2);
  EXPECT_DOUBLE_EQ(testing::evaluate_once(problem, inputs, states).tracking, 0.0);  // no tube by default
  EXPECT_EQ(problem.tube_excess(states), Eigen::Vector2d::Zero());
  ASSERT_TRUE(problem.set_tube(1, 0.2, 0.1));
  EXPECT_NEAR(testing::evaluate_once(problem, inputs, states).tracking, 100.0 * (0.3 * 0.3 + 0.4 * 0.4), 1e-12);
  EXPECT_NEAR(problem.tube_excess(states).x(), 0.3, 1e-12);
  EXPECT_NEAR(problem.tube_excess(states).y(), 0.4, 1e-12);
  ASSERT_TRUE(problem.set_tube(1, 0.6, 0.6));  // inside: free
  EXPECT_DOUBLE_EQ(testing::evaluate_once(problem, inputs, states).tracking, 0.0);
  EXPECT_EQ(problem.tube_excess(states), Eigen::Vector2d::Zero());
  problem.clear_tube();
  ASSERT_TRUE(problem.set_tube(1, 0.2, 0.1));
  EXPECT_FALSE(problem.set_tube(1, 0.0, 0.1));
  EXPECT_FALSE(problem.set_tube(1, 0.2, std::nan("")));
  EXPECT_FALSE(problem.set_tube(2, 0.2, 0.1));  // beyond the horizon
  EXPECT_NEAR(problem.tube()(0, 0), 0.2, 0.0);  // the rejected calls changed nothing
}

TEST(OcpProblem, TheTubeGradientMatchesFiniteDifferencesOutsideTheTube) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w = hand_weights();
  w.tube_penalty = 1e3;
  OcpProblem problem(model, 2, 1.0, w, {});
  ASSERT_TRUE(problem.set_tube(1, 0.05, 0.02));
  ASSERT_TRUE(problem.set_reference(1, Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector3d::Zero()));
  Eigen::VectorXd x_next(6);
  x_next << 0.3, 0.1, -0.2, 0.5, 0.0, 0.1;  // 0.36 m and 0.5 rad off: outside on both
  const Eigen::VectorXd u = Eigen::Vector3d(0.2, -0.1, 0.3), u_before = Eigen::Vector3d::Zero();
  Eigen::VectorXd d_x(6), d_u(3), d_u_before(3), scratch_x(6), scratch_u(3), scratch_before(3);
  problem.stage_cost_without_wear(0, x_next, u, u_before, d_x, d_u, d_u_before);
  for (int i = 0; i < 3; ++i) {
    const double h = 1e-6;
    Eigen::VectorXd plus = x_next, minus = x_next;
    plus[i] += h;
    minus[i] -= h;
    const double numeric = (problem.stage_cost_without_wear(0, plus, u, u_before, scratch_x, scratch_u, scratch_before) -
                            problem.stage_cost_without_wear(0, minus, u, u_before, scratch_x, scratch_u, scratch_before)) /
                           (2 * h);
    EXPECT_NEAR(d_x[i], numeric, 1e-4 * std::max(1.0, std::abs(numeric))) << "state " << i;
  }
}

// The residuals are the cost's one definition: by hand, for the case above (Q = (10, 10, 5), Q_N =
// 10 Q, R = 1, S = 2): x1 = 0.5 m gives sqrt(2 * 10) * 0.5, x2 = 1.5 m at the horizon's end
// sqrt(2 * 100) * 1.5; the effort and rate residuals are sqrt(2) u and 2 (u_k - u_{k-1}).
TEST(OcpProblem, ResidualsAreTheSquareRootsOfTheHandComputedTerms) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w = hand_weights();
  w.twist = {4.0, 0.0, 0.0};
  OcpProblem problem(model, 2, 1.0, w, {});
  OcpProblem::TrackingResiduals r;
  Eigen::VectorXd x_next = Eigen::VectorXd::Zero(6);
  x_next[0] = 0.5;
  x_next[3] = 1.0;
  problem.tracking_residuals(0, x_next, &r);
  EXPECT_NEAR(r[OcpProblem::kPoseResidual], std::sqrt(20.0) * 0.5, 1e-15);
  EXPECT_NEAR(r[OcpProblem::kTwistResidual], std::sqrt(8.0) * 1.0, 1e-15);
  EXPECT_EQ(r[OcpProblem::kTubeResidual], 0.0);  // no tube: no excess
  x_next[0] = 1.5;
  problem.tracking_residuals(1, x_next, &r);
  EXPECT_NEAR(r[OcpProblem::kPoseResidual], std::sqrt(200.0) * 1.5, 1e-14);
  EXPECT_NEAR(problem.effort_root()[0], std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(problem.rate_root()[2], 2.0, 1e-15);
  // Half the squared residuals is the stage cost without wear.
  Eigen::VectorXd d_x(6), d_u(3), d_u_before(3);
  const Eigen::Vector3d u(1.0, 0.0, 0.0), u_before = Eigen::Vector3d::Zero();
  const double expected = 0.5 * r.squaredNorm() + 0.5 * 2.0 * 1.0 + 0.5 * 4.0 * 1.0;
  EXPECT_NEAR(problem.stage_cost_without_wear(1, x_next, u, u_before, d_x, d_u, d_u_before), expected, 1e-12);
}

// d r / d x_{k+1} of stage k at x_next against central differences, every residual row and state.
void expect_tracking_jacobian_matches_central_differences(const OcpProblem& problem, int k,
                                                          const Eigen::VectorXd& x_next) {
  OcpProblem::TrackingResiduals r, plus_r, minus_r;
  OcpProblem::TrackingJacobian jacobian;
  problem.tracking_residuals(k, x_next, &r, &jacobian);
  for (int i = 0; i < OcpProblem::kTrackedStates; ++i) {
    const double h = 1e-7;
    Eigen::VectorXd plus = x_next, minus = x_next;
    plus[i] += h;
    minus[i] -= h;
    problem.tracking_residuals(k, plus, &plus_r);
    problem.tracking_residuals(k, minus, &minus_r);
    const OcpProblem::TrackingResiduals numeric = (plus_r - minus_r) / (2 * h);
    for (int row = 0; row < OcpProblem::kTrackingResiduals; ++row) {
      EXPECT_NEAR(jacobian(row, i), numeric[row], 1e-6 * std::max(1.0, std::abs(numeric[row])))
          << "row " << row << ", state " << i;
    }
  }
}

// d r / d x_{k+1} against central differences, with the heading wrapped across +-pi and the tube
// active on both errors (its rows are where a sign or a norm could go wrong).
TEST(OcpProblem, TrackingJacobianMatchesCentralDifferences) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w = hand_weights();
  w.twist = {3.0, 2.0, 1.0};
  w.tube_penalty = 50.0;
  OcpProblem problem(model, 3, 1.0, w, {});
  ASSERT_TRUE(problem.set_reference(2, Eigen::Vector3d(0.1, -0.2, 3.0), Eigen::Vector3d(0.5, 0.0, -0.1)));
  ASSERT_TRUE(problem.set_tube(2, 0.05, 0.02));
  Eigen::VectorXd x_next(6);
  x_next << 0.4, 0.1, -3.0, 0.2, -0.3, 0.4;  // heading error 0.28 rad once wrapped
  OcpProblem::TrackingResiduals r;
  problem.tracking_residuals(1, x_next, &r);
  ASSERT_GT(r[OcpProblem::kTubeResidual], 0.0);
  ASSERT_GT(r[OcpProblem::kTubeResidual + 1], 0.0);
  expect_tracking_jacobian_matches_central_differences(problem, 1, x_next);
}

// The pseudo-Huber pose cost: the quadratic Q e^2 becomes 2 Q d^2 (sqrt(1 + (e/d)^2) - 1), by hand
// and in its two limits: Q e^2 for small errors and the slope 2 Q d (the quadratic's at d) for
// large ones. The heading's width is the angle that costs what a position error of d costs:
// d sqrt(Q_xy / Q_psi).
TEST(OcpProblem, APseudoHuberWidthPricesLargePoseErrorsLinearlyAndSmallOnesQuadratically) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w;
  w.pose = {10.0, 10.0, 40.0};
  w.pose_huber_width = 0.1;
  OcpProblem problem(model, 2, 1.0, w, {});
  const auto pose_cost = [&](double x, double y, double psi) {
    Eigen::VectorXd x_next = Eigen::VectorXd::Zero(6);
    x_next << x, y, psi, 0.0, 0.0, 0.0;
    OcpProblem::TrackingResiduals r;
    problem.tracking_residuals(0, x_next, &r);
    return 0.5 * r.segment<3>(OcpProblem::kPoseResidual).squaredNorm();
  };
  // |e| = 0.5 = 5 d: 2 * 10 * 0.01 * (sqrt(26) - 1) = 0.82, against 2.5 for the quadratic.
  EXPECT_NEAR(pose_cost(0.3, 0.4, 0.0), 0.2 * (std::sqrt(26.0) - 1.0), 1e-14);
  EXPECT_NEAR(pose_cost(1e-4, 0.0, 0.0) / (10.0 * 1e-8), 1.0, 1e-6);  // 1 - (e/d)^2 / 4 to second order
  EXPECT_NEAR(pose_cost(0.0, 20.0, 0.0) - pose_cost(0.0, 19.0, 0.0), 2.0 * 10.0 * 0.1, 1e-3);
  // Heading width 0.1 * sqrt(10 / 40) = 0.05 rad.
  EXPECT_NEAR(pose_cost(0.0, 0.0, 0.05), pose_cost(0.1, 0.0, 0.0), 1e-15);
  EXPECT_NEAR(pose_cost(0.0, 0.0, 0.05), 0.2 * (std::sqrt(2.0) - 1.0), 1e-15);
  // The terminal stage keeps the same widths, at terminal_scale times the weights.
  Eigen::VectorXd x_next = Eigen::VectorXd::Zero(6);
  x_next[1] = 0.5;
  OcpProblem::TrackingResiduals r;
  problem.tracking_residuals(1, x_next, &r);
  EXPECT_NEAR(0.5 * r.squaredNorm(), w.terminal_scale * 0.2 * (std::sqrt(26.0) - 1.0), 1e-12);
}

// The same central-difference check with the pseudo-Huber width on, at an error far beyond it, one
// near it and one at zero (where d |e| / d e has no limit, but the residual is smooth).
TEST(OcpProblem, TrackingJacobianWithAPseudoHuberWidthMatchesCentralDifferences) {
  const DoubleIntegratorModel model(1.0);
  CostWeights w = hand_weights();
  w.pose = {10.0, 6.0, 40.0};
  w.pose_huber_width = 0.1;
  OcpProblem problem(model, 3, 1.0, w, {});
  const Eigen::Vector3d errors[] = {{0.4, -0.7, 0.9}, {0.06, 0.05, -0.04}, {0.0, 0.0, 0.0}};
  for (const Eigen::Vector3d& error : errors) {
    SCOPED_TRACE(error.transpose());
    Eigen::VectorXd x_next = Eigen::VectorXd::Zero(6);
    x_next.head<3>() = error;
    expect_tracking_jacobian_matches_central_differences(problem, 1, x_next);
  }
}

// The problem holds no scratch and the model's lives in the caller's PredictionData (issue 16):
// rollouts of the swerve problem on two threads at once, each on its own data, give bit for bit
// what one thread gives. Both prediction methods (the semi-implicit step and RK4, whose stages
// are scratch too).
TEST(OcpProblem, RolloutsOnTheirOwnDataOnTwoThreadsMatchOneThreadBitForBit) {
  for (const PredictionMethod method : {PredictionMethod::kSemiImplicit, PredictionMethod::kRk4}) {
    SCOPED_TRACE(to_string(method));
    PredictionOptions options;
    options.method = method;
    options.substeps = method == PredictionMethod::kRk4 ? 10 : 1;
    const VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
    const TwistPredictionModel model(params, options);
    OcpProblem problem(model, 20, 0.05, testing::SwerveTestProblem::weights(testing::SwerveScene::kTurn),
                       testing::SwerveTestProblem::bounds(testing::SwerveScene::kTurn, -1.0));
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(model.state_size());
    x0.segment<3>(3) = Eigen::Vector3d(0.5, 0.0, 0.1);
    ASSERT_TRUE(problem.set_initial_state(x0));
    constexpr int kPlans = 16;
    std::vector<Eigen::MatrixXd> plans;
    std::mt19937 random(5);
    std::uniform_real_distribution<double> jitter(-0.1, 0.1);
    for (int p = 0; p < kPlans; ++p) {
      Eigen::MatrixXd inputs(3, problem.horizon());
      for (int k = 0; k < problem.horizon(); ++k) {
        inputs.col(k) = Eigen::Vector3d(0.55 + jitter(random), jitter(random), 0.15 + jitter(random));
      }
      problem.project(inputs);
      plans.push_back(inputs);
    }
    const auto roll = [&](PredictionData& data, int p, Eigen::MatrixXd* states) {
      *states = Eigen::MatrixXd::Zero(model.state_size(), problem.horizon() + 1);
      Eigen::VectorXd stage_costs(problem.horizon());
      return problem.rollout(data, plans[static_cast<std::size_t>(p)], 0, *states, stage_costs);
    };
    std::vector<double> expected_cost(kPlans);
    std::vector<Eigen::MatrixXd> expected_states(kPlans);
    {
      const std::unique_ptr<PredictionData> data = model.create_data();
      ASSERT_NE(data, nullptr);
      for (int p = 0; p < kPlans; ++p) {
        const auto index = static_cast<std::size_t>(p);
        expected_cost[index] = roll(*data, p, &expected_states[index]);
        ASSERT_TRUE(std::isfinite(expected_cost[index]));
      }
    }
    const auto mismatches = testing::mismatches_on_two_threads(
        kPlans, 4, [&] { return model.create_data(); },
        [&](const std::unique_ptr<PredictionData>& data, int p) {
          const auto index = static_cast<std::size_t>(p);
          Eigen::MatrixXd states;
          const double cost = roll(*data, p, &states);
          return cost == expected_cost[index] && states == expected_states[index];
        });
    EXPECT_EQ(mismatches[0], 0);
    EXPECT_EQ(mismatches[1], 0);
  }
}

TEST(OcpProblem, ConstructionValidatesEveryField) {
  const DoubleIntegratorModel model;
  EXPECT_EQ(testing::config_error_of([&] { OcpProblem(model, 0, 0.1, {}, {}); }), "OcpProblem.horizon = 0: must be in [1, 1000]");
  EXPECT_EQ(testing::config_error_of([&] { OcpProblem(model, 5, -0.1, {}, {}); }), "OcpProblem.dt = -0.1: must be finite and > 0");
  CostWeights negative;
  negative.wear = -1.0;
  EXPECT_EQ(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, negative, {}); }),
            "OcpProblem.weights.wear = -1: must be finite and >= 0");
  CostWeights negative_width;
  negative_width.pose_huber_width = -0.1;
  EXPECT_EQ(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, negative_width, {}); }),
            "OcpProblem.weights.pose_huber_width = -0.1: must be finite and >= 0");
  CostWeights negative_pose;
  negative_pose.pose = {10.0, -1.0, 5.0};
  EXPECT_EQ(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, negative_pose, {}); }),
            "OcpProblem.weights.pose = [10, -1, 5]: must be finite and >= 0 on every axis");
  CostWeights infinite_twist;
  infinite_twist.twist = {0.0, std::numeric_limits<double>::infinity(), 0.0};
  EXPECT_NE(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, infinite_twist, {}); }).find("OcpProblem.weights.twist"),
            std::string::npos);
  CostWeights wrong_size;
  wrong_size.effort = Eigen::VectorXd::Ones(2);
  EXPECT_NE(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, wrong_size, {}); }).find("weights.effort.size() = 2"),
            std::string::npos);
  InputBounds inverted;
  inverted.lower = Eigen::Vector3d(0, 2, 0);
  inverted.upper = Eigen::Vector3d(1, 1, 1);
  EXPECT_NE(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, {}, inverted); }).find("OcpProblem.bounds.lower[1] = 2"),
            std::string::npos);
  InputBounds zero_step;
  zero_step.max_step = Eigen::Vector3d(1, 0, 1);
  EXPECT_NE(testing::config_error_of([&] { OcpProblem(model, 5, 0.1, {}, zero_step); }), "");
}

}  // namespace
}  // namespace swerve
