// The prediction step's exact Jacobians (SemiImplicitStepJacobian) against central differences of
// the double step itself, with module inputs and with the body twist as the input; their values
// against the double step's; bad arguments and scratch made for another Jacobian; and two callers
// on two threads.
#include "swerve/models/semi_implicit_step_jacobian.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "support/model_fixtures.hpp"
#include "support/two_threads.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/kinematics/se2.hpp"

namespace swerve {
namespace {

constexpr double kDt = 0.05;

// The shipped default's prediction: both actuator lags as states.
PredictionOptions lagged() {
  PredictionOptions options;
  options.drive_lag = true;
  options.steering_lag = true;
  return options;
}

// A turning body whose modules sit a little off their rolling angles, wheels and steering drives
// moving: every state and input matters.
Eigen::VectorXd turning_state(const SemiImplicitStep<double>& step, const VehicleParams& params) {
  const int n = params.layout.size();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(step.state_size());
  x[StateIndex::kPsi] = 0.4;
  x.segment<3>(StateIndex::kVx) << 0.8, 0.1, 0.3;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = params.layout.position_body(i);
    x[StateIndex::steering(i)] = std::atan2(0.1 + 0.3 * p.x(), 0.8 - 0.3 * p.y()) + 0.02 * (i + 1);
  }
  const int prefix = StateIndex::prefix_size(n);
  for (int k = prefix; k < step.state_size(); ++k) x[k] = k < prefix + step.wheel_speed_states() ? 7.0 + 0.1 * k : 0.05;
  return x;
}

// Central differences of (x_next, wear) of `evaluate(x, input)` over the stacked (x, input).
template <typename Evaluate>
void central_differences(const Eigen::VectorXd& x, const Eigen::VectorXd& input, const Evaluate& evaluate,
                         Eigen::MatrixXd* a, Eigen::MatrixXd* b, Eigen::VectorXd* wear_gradient) {
  const Eigen::Index nx = x.size(), nu = input.size();
  Eigen::VectorXd plus(nx), minus(nx);
  for (Eigen::Index j = 0; j < nx + nu; ++j) {
    Eigen::VectorXd xp = x, xm = x, up = input, um = input;
    const double h = 1e-6 * (1.0 + std::abs(j < nx ? x[j] : input[j - nx]));
    (j < nx ? xp[j] : up[j - nx]) += h;
    (j < nx ? xm[j] : um[j - nx]) -= h;
    double wear_plus = 0.0, wear_minus = 0.0;
    ASSERT_TRUE(evaluate(xp, up, plus, &wear_plus));
    ASSERT_TRUE(evaluate(xm, um, minus, &wear_minus));
    Eigen::VectorXd column = (plus - minus) / (2.0 * h);
    column[StateIndex::kPsi] = wrap_angle(plus[StateIndex::kPsi] - minus[StateIndex::kPsi]) / (2.0 * h);
    (j < nx ? a->col(j) : b->col(j - nx)) = column;
    (*wear_gradient)[j] = (wear_plus - wear_minus) / (2.0 * h);
  }
}

double relative_error(const Eigen::MatrixXd& exact, const Eigen::MatrixXd& fd) {
  return ((exact - fd).array().abs() / fd.array().abs().max(1.0)).maxCoeff();
}

// The module-input Jacobian at (x, u): its value is the double step's, and a, b and the wear's
// gradient are the step's central differences within `tolerance` (ten times that on the wear).
void expect_module_jacobian_matches_the_step(const SemiImplicitStep<double>& step,
                                             SemiImplicitStep<double>::Data& step_data,
                                             const SemiImplicitStepJacobian& jacobian,
                                             SemiImplicitStepJacobian::Data& data, const Eigen::VectorXd& x,
                                             const Eigen::VectorXd& u, double tolerance) {
  const Eigen::Index nx = x.size(), nu = u.size();
  Eigen::VectorXd x_next(nx), wear_gradient(nx + nu), value(nx);
  Eigen::MatrixXd a(nx, nx), b(nx, nu);
  double wear = 0.0, value_wear = 0.0;
  ASSERT_TRUE(jacobian.module_step(data, x, u, kDt, x_next, a, b, &wear, wear_gradient));
  ASSERT_TRUE(step.step(step_data, x, u, kDt, value, &value_wear));
  EXPECT_LT((x_next - value).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_NEAR(wear, value_wear, 1e-10 * (1.0 + value_wear));
  Eigen::MatrixXd fd_a(nx, nx), fd_b(nx, nu);
  Eigen::VectorXd fd_wear(nx + nu);
  central_differences(x, u, [&](const Eigen::VectorXd& xs, const Eigen::VectorXd& input, Eigen::VectorXd& next,
                                double* w) { return step.step(step_data, xs, input, kDt, next, w); },
                      &fd_a, &fd_b, &fd_wear);
  EXPECT_LT(relative_error(a, fd_a), tolerance);
  EXPECT_LT(relative_error(b, fd_b), tolerance);
  EXPECT_LT(relative_error(wear_gradient, fd_wear), 10.0 * tolerance);
}

class SemiImplicitStepJacobianTest : public ::testing::Test {
 protected:
  SemiImplicitStepJacobianTest()
      : params_(testing::make_params(4)), step_(params_, lagged()), step_data_(step_), jacobian_(params_, lagged()),
        data_(jacobian_), x_(turning_state(step_, params_)) {}

  VehicleParams params_;
  SemiImplicitStep<double> step_;
  SemiImplicitStep<double>::Data step_data_;
  SemiImplicitStepJacobian jacobian_;
  SemiImplicitStepJacobian::Data data_;
  Eigen::VectorXd x_;
};

TEST_F(SemiImplicitStepJacobianTest, ModuleInputsGiveTheDoubleStepsValueAndItsCentralDifferences) {
  ASSERT_EQ(jacobian_.state_size(), step_.state_size());
  Eigen::VectorXd u(jacobian_.input_size());
  step_.module_inputs(x_, Eigen::Vector3d(0.85, 0.05, 0.25), kDt, u);
  expect_module_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, u, 1e-5);
}

// The twist-input Jacobian at (x, twist): the double step's value through the module map, and
// its central differences.
void expect_twist_jacobian_matches_the_step(const SemiImplicitStep<double>& step,
                                            SemiImplicitStep<double>::Data& step_data,
                                            const SemiImplicitStepJacobian& jacobian,
                                            SemiImplicitStepJacobian::Data& data, const Eigen::VectorXd& x_at,
                                            const Eigen::Vector3d& twist) {
  const int nx = jacobian.state_size();
  Eigen::VectorXd x_next(nx), wear_gradient(nx + 3);
  Eigen::MatrixXd a(nx, nx), b(nx, 3);
  double wear = 0.0;
  ASSERT_TRUE(jacobian.twist_step(data, x_at, twist, kDt, x_next, a, b, &wear, wear_gradient));
  Eigen::VectorXd inputs(jacobian.input_size());
  const auto twist_step = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& t, Eigen::VectorXd& next, double* w) {
    step.module_inputs(x, Eigen::Vector3d(t), kDt, inputs);
    return step.step(step_data, x, inputs, kDt, next, w);
  };
  Eigen::VectorXd value(nx);
  double value_wear = 0.0;
  ASSERT_TRUE(twist_step(x_at, twist, value, &value_wear));
  EXPECT_LT((x_next - value).cwiseAbs().maxCoeff(), 1e-10);

  Eigen::MatrixXd fd_a(nx, nx), fd_b(nx, 3);
  Eigen::VectorXd fd_wear(nx + 3);
  central_differences(x_at, twist, twist_step, &fd_a, &fd_b, &fd_wear);
  EXPECT_LT(relative_error(a, fd_a), 1e-5);
  EXPECT_LT(relative_error(b, fd_b), 1e-5);
  EXPECT_LT(relative_error(wear_gradient, fd_wear), 1e-4);
  // The twist's columns are the module inputs' chained through the map: not zero.
  EXPECT_GT(b.cwiseAbs().maxCoeff(), 1e-3);
}

TEST_F(SemiImplicitStepJacobianTest, TheTwistInputDifferentiatesThroughTheModuleMapToo) {
  expect_twist_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, Eigen::Vector3d(0.85, 0.05, 0.25));
}

TEST_F(SemiImplicitStepJacobianTest, WithAStuckSteeringTheAngleHoldsAndTheJacobiansStillMatchTheStep) {
  ModuleFaults faults(4, ModuleFault::kNone);
  faults[1] = ModuleFault::kStuckSteering;
  step_.observe_module_faults(&faults);
  jacobian_.observe_module_faults(&faults);
  Eigen::VectorXd u(jacobian_.input_size());
  step_.module_inputs(x_, Eigen::Vector3d(0.85, 0.05, 0.25), kDt, u);
  EXPECT_EQ(u[InputIndex::steering_rate(1)], 0.0);  // the map leaves it alone
  u[InputIndex::steering_rate(1)] = 2.0;            // and the step ignores a rate commanded anyway
  Eigen::VectorXd x_next(step_.state_size());
  ASSERT_TRUE(step_.step(step_data_, x_, u, kDt, x_next, nullptr));
  EXPECT_EQ(x_next[StateIndex::steering(1)], x_[StateIndex::steering(1)]);
  EXPECT_NE(x_next[StateIndex::steering(0)], x_[StateIndex::steering(0)]);
  expect_module_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, u, 1e-5);
  expect_twist_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, Eigen::Vector3d(0.85, 0.05, 0.25));
}

TEST_F(SemiImplicitStepJacobianTest, WithADeadDriveItsWheelSpeedMovesNothingAndTheJacobiansStillMatchTheStep) {
  ModuleFaults faults(4, ModuleFault::kNone);
  faults[2] = ModuleFault::kDeadDrive;
  step_.observe_module_faults(&faults);
  jacobian_.observe_module_faults(&faults);
  Eigen::VectorXd u(jacobian_.input_size());
  step_.module_inputs(x_, Eigen::Vector3d(0.85, 0.05, 0.25), kDt, u);
  Eigen::VectorXd x_next(step_.state_size()), x_spun(step_.state_size());
  double wear = 0.0, wear_spun = 0.0;
  ASSERT_TRUE(step_.step(step_data_, x_, u, kDt, x_next, &wear));
  Eigen::VectorXd spun = u;
  spun[InputIndex::wheel_speed(2)] *= 3.0;  // a free wheel: what its drive is told does not reach the body
  ASSERT_TRUE(step_.step(step_data_, x_, spun, kDt, x_spun, &wear_spun));
  EXPECT_LT((x_spun.head(6) - x_next.head(6)).norm(), 1e-12);
  EXPECT_NEAR(wear_spun, wear, 1e-9 * wear);
  expect_module_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, u, 1e-5);
  expect_twist_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, Eigen::Vector3d(0.85, 0.05, 0.25));
}

// The stage wear of (x, u) on `step` with `weights` observed (null: none).
double weighted_stage_wear(SemiImplicitStep<double>& step, SemiImplicitStep<double>::Data& data, const double* weights,
                           const Eigen::VectorXd& x, const Eigen::VectorXd& u, Eigen::VectorXd* x_next = nullptr) {
  step.observe_wear_weights(weights);
  Eigen::VectorXd next(x.size());
  double wear = -1.0;
  EXPECT_TRUE(step.step(data, x, u, kDt, next, &wear));
  step.observe_wear_weights(nullptr);
  if (x_next != nullptr) *x_next = next;
  return wear;
}

TEST_F(SemiImplicitStepJacobianTest, WearWeightsSplitTheStageWearByModuleAndWeightsOfOneChangeNothing) {
  Eigen::VectorXd u(jacobian_.input_size());
  step_.module_inputs(x_, Eigen::Vector3d(0.95, 0.15, 0.45), kDt, u);  // a change of twist: a transient too
  const double plain = weighted_stage_wear(step_, step_data_, nullptr, x_, u);
  ASSERT_GT(plain, 1e-4);
  const double ones[4] = {1.0, 1.0, 1.0, 1.0};
  EXPECT_NEAR(weighted_stage_wear(step_, step_data_, ones, x_, u), plain, 1e-12 * plain);
  // Module by module (a weight of 1 on one module, 0 on the others): the four shares are each
  // >= 0 and add up to the whole, and the wear is linear in the weights.
  double shares[4], sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    double unit[4] = {0.0, 0.0, 0.0, 0.0};
    unit[i] = 1.0;
    shares[i] = weighted_stage_wear(step_, step_data_, unit, x_, u);
    EXPECT_GE(shares[i], 0.0) << "module " << i;
    sum += shares[i];
  }
  EXPECT_NEAR(sum, plain, 1e-12 * plain);
  const double mixed[4] = {2.0, 0.5, 0.0, 3.0};
  EXPECT_NEAR(weighted_stage_wear(step_, step_data_, mixed, x_, u),
              2.0 * shares[0] + 0.5 * shares[1] + 3.0 * shares[3], 1e-12 * plain);
  // In a turn the modules slide unequally, so the weights have something to weigh.
  EXPECT_GT(*std::max_element(shares, shares + 4), 1.05 * *std::min_element(shares, shares + 4));
}

TEST(SemiImplicitStepJacobian, OnASymmetricVehicleDrivingStraightBothSidesCarryHalfTheWear) {
  // Independent truth by symmetry: two modules mirrored about the body's x axis, accelerating
  // straight ahead, wear alike; each one's share is half of the whole.
  const VehicleParams params = testing::make_params(2);
  ASSERT_NEAR(params.layout.position_body(0).y(), -params.layout.position_body(1).y(), 1e-12);
  ASSERT_NEAR(params.layout.position_body(0).x(), params.layout.position_body(1).x(), 1e-12);
  SemiImplicitStep<double> step(params, lagged());
  SemiImplicitStep<double>::Data data(step);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(step.state_size());
  x[StateIndex::kVx] = 0.5;
  const int prefix = StateIndex::prefix_size(2);
  for (int k = prefix; k < prefix + step.wheel_speed_states(); ++k) x[k] = 0.5 / params.layout.wheel_radius();
  Eigen::VectorXd u(step.model().input_size());
  step.module_inputs(x, Eigen::Vector3d(0.8, 0.0, 0.0), kDt, u);
  const double whole = weighted_stage_wear(step, data, nullptr, x, u);
  ASSERT_GT(whole, 1e-4);
  const double left[2] = {1.0, 0.0}, right[2] = {0.0, 1.0};
  EXPECT_NEAR(weighted_stage_wear(step, data, left, x, u), 0.5 * whole, 1e-9 * whole);
  EXPECT_NEAR(weighted_stage_wear(step, data, right, x, u), 0.5 * whole, 1e-9 * whole);
}

TEST(SemiImplicitStepJacobian, WithoutATransientAModulesWeightChargesItsOwnWearRateAtTheStepsEnd) {
  // Independent truth: with Archard wear the stage wear is h times the wear rate at the step's end
  // (no energy balance, so no transient share), and a unit weight on module i charges module i's
  // own rate there: the vehicle model's diagnostics at the state the step ends in. A turning state
  // makes every module's rate different, so a module mistaken for another shows.
  VehicleParams params = testing::make_params(4);
  params.wear.model = WearModelKind::kArchard;
  SemiImplicitStep<double> step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data data(step);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(step.state_size());
  x.segment<3>(StateIndex::kVx) << 0.8, 0.1, 0.3;
  for (int i = 0; i < 4; ++i) x[StateIndex::steering(i)] = 0.05 * (i + 1);
  Eigen::VectorXd u(step.model().input_size());
  step.module_inputs(x, Eigen::Vector3d(0.9, 0.0, 0.5), kDt, u);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  std::vector<ModuleDiagnostics<double>> diagnostics(4);
  Eigen::VectorXd rates(step.state_size());
  double shares[4];
  for (int i = 0; i < 4; ++i) {
    double unit[4] = {0.0, 0.0, 0.0, 0.0};
    unit[i] = 1.0;
    Eigen::VectorXd x_next;
    shares[i] = weighted_stage_wear(step, data, unit, x, u, &x_next);
    double total_rate = 0.0;
    ASSERT_EQ(model.derivative(x_next, u, rates, diagnostics.data(), &total_rate), ModelStatus::kOk);
    EXPECT_NEAR(shares[i], kDt * diagnostics[static_cast<std::size_t>(i)].wear_rate, 1e-9 * kDt * total_rate)
        << "module " << i;
  }
  EXPECT_GT(*std::max_element(shares, shares + 4), 1.05 * *std::min_element(shares, shares + 4));
}

TEST_F(SemiImplicitStepJacobianTest, WithWearWeightsTheJacobiansStillMatchTheStep) {
  const double weights[4] = {0.25, 1.0, 2.5, 4.0};
  step_.observe_wear_weights(weights);
  jacobian_.observe_wear_weights(weights);
  Eigen::VectorXd u(jacobian_.input_size());
  step_.module_inputs(x_, Eigen::Vector3d(0.85, 0.05, 0.25), kDt, u);
  expect_module_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, u, 1e-5);
  expect_twist_jacobian_matches_the_step(step_, step_data_, jacobian_, data_, x_, Eigen::Vector3d(0.85, 0.05, 0.25));
}

TEST(SemiImplicitStepJacobian, ASplitSubstepIsDifferentiatedAsTheDoubleStepTakesIt) {
  // From rest, wheels told to spin up while their modules still turn slip past the tyres' force
  // peak, and Newton finds no root over the whole substep: the step splits it. The Jacobian's first
  // chunk records the split and the later chunks replay it.
  const VehicleParams params = testing::make_params(4);
  // No lags, so the wheels jump to their commands; two Newton iterations, so that a hard substep
  // splits rather than converging with more.
  PredictionOptions options;
  options.max_newton_iterations = 2;
  const SemiImplicitStep<double> step(params, options);
  SemiImplicitStep<double>::Data step_data(step);
  const SemiImplicitStepJacobian jacobian(params, options);
  SemiImplicitStepJacobian::Data data(jacobian);
  const int nx = jacobian.state_size(), nu = jacobian.input_size();
  const int n = params.layout.size();
  Eigen::VectorXd x(nx), u(nu), value(nx);
  double value_wear = 0.0;
  bool split = false;
  // The first of a few start-ups, modules turned off the motion and wheels spinning up, that splits.
  for (double spin = 5.0; spin <= 80.0 && !split; spin *= 2.0) {
    for (double angle = 0.4; angle <= 1.6 && !split; angle += 0.4) {
      x.setZero();
      u.setZero();
      for (int i = 0; i < n; ++i) {
        x[StateIndex::steering(i)] = angle * (i % 2 == 0 ? 1.0 : -1.0);
        u[InputIndex::wheel_speed(i)] = spin;
        u[InputIndex::steering_rate(i)] = -0.5 * x[StateIndex::steering(i)];
      }
      std::fill(step_data.split.begin(), step_data.split.end(), 0);
      if (!step.step(step_data, x, u, kDt, value, &value_wear)) continue;  // split to the limit and failed
      for (const char solve_split : step_data.split) split = split || solve_split != 0;
    }
  }
  ASSERT_TRUE(split) << "no start-up splits a substep any more";
  // Two iterations leave the twist converged to 1e-8 rather than 1e-10, and the differences carry
  // that: a looser bound than the other cases, still far below a wrong chain (order one).
  expect_module_jacobian_matches_the_step(step, step_data, jacobian, data, x, u, 1e-4);
}

TEST_F(SemiImplicitStepJacobianTest, RefusesWrongSizesNonFiniteValuesBadOptionsAndForeignScratch) {
  const int nx = jacobian_.state_size(), nu = jacobian_.input_size();
  Eigen::VectorXd u = Eigen::VectorXd::Zero(nu), x_next(nx), wear_gradient(nx + nu);
  Eigen::MatrixXd a(nx, nx), b(nx, nu);
  double wear = 0.0;
  ASSERT_TRUE(jacobian_.module_step(data_, x_, u, kDt, x_next, a, b, &wear, wear_gradient));
  Eigen::VectorXd short_u = Eigen::VectorXd::Zero(nu - 1);
  EXPECT_FALSE(jacobian_.module_step(data_, x_, short_u, kDt, x_next, a, b, &wear, wear_gradient));
  Eigen::VectorXd nan_x = x_;
  nan_x[StateIndex::kVx] = std::nan("");
  EXPECT_FALSE(jacobian_.module_step(data_, nan_x, u, kDt, x_next, a, b, &wear, wear_gradient));
  EXPECT_FALSE(jacobian_.module_step(data_, x_, u, 0.0, x_next, a, b, &wear, wear_gradient));
  EXPECT_FALSE(jacobian_.module_step(data_, x_, u, INFINITY, x_next, a, b, &wear, wear_gradient));
  Eigen::MatrixXd twist_b(nx, 3);
  Eigen::VectorXd twist_gradient(nx + 3);
  EXPECT_FALSE(jacobian_.twist_step(data_, x_, Eigen::Vector3d(NAN, 0, 0), kDt, x_next, a, twist_b, &wear, twist_gradient));
  EXPECT_FALSE(jacobian_.twist_step(data_, x_, Eigen::Vector3d(0.5, 0, 0), kDt, x_next, a, b, &wear, wear_gradient));
  // Scratch made for another vehicle's Jacobian (other sizes inside), or moved from.
  const SemiImplicitStepJacobian other(testing::make_params(8), lagged());
  SemiImplicitStepJacobian::Data foreign(other);
  EXPECT_FALSE(jacobian_.module_step(foreign, x_, u, kDt, x_next, a, b, &wear, wear_gradient));
  SemiImplicitStepJacobian::Data moved_to(std::move(data_));
  EXPECT_FALSE(jacobian_.module_step(data_, x_, u, kDt, x_next, a, b, &wear, wear_gradient));  // NOLINT(bugprone-use-after-move)
  EXPECT_TRUE(jacobian_.module_step(moved_to, x_, u, kDt, x_next, a, b, &wear, wear_gradient));
  PredictionOptions bad;
  bad.substeps = 0;
  EXPECT_THROW(SemiImplicitStepJacobian(params_, bad), ConfigError);
}

TEST_F(SemiImplicitStepJacobianTest, CallersWithDataOfTheirOwnOnTwoThreadsGetTheOneThreadAnswerBitForBit) {
  const int nx = jacobian_.state_size();
  struct Result {
    Eigen::MatrixXd a, b;
    Eigen::VectorXd gradient;
  };
  std::vector<Eigen::Vector3d> twists;
  std::vector<Result> alone;
  for (int k = 0; k < 6; ++k) {
    twists.emplace_back(0.1 + 0.15 * k, 0.02 * k, 0.3 - 0.1 * k);
    Result r{Eigen::MatrixXd(nx, nx), Eigen::MatrixXd(nx, 3), Eigen::VectorXd(nx + 3)};
    Eigen::VectorXd next(nx);
    double wear = 0.0;
    ASSERT_TRUE(jacobian_.twist_step(data_, x_, twists.back(), kDt, next, r.a, r.b, &wear, r.gradient));
    alone.push_back(r);
  }
  const auto mismatches = testing::mismatches_on_two_threads(
      static_cast<int>(twists.size()), 4, [&] { return SemiImplicitStepJacobian::Data(jacobian_); },
      [&](SemiImplicitStepJacobian::Data& data, int job) {
        Result r{Eigen::MatrixXd(nx, nx), Eigen::MatrixXd(nx, 3), Eigen::VectorXd(nx + 3)};
        Eigen::VectorXd next(nx);
        double wear = 0.0;
        const auto k = static_cast<std::size_t>(job);
        return jacobian_.twist_step(data, x_, twists[k], kDt, next, r.a, r.b, &wear, r.gradient) &&
               r.a == alone[k].a && r.b == alone[k].b && r.gradient == alone[k].gradient;
      });
  EXPECT_EQ(mismatches[0], 0);
  EXPECT_EQ(mismatches[1], 0);
}

}  // namespace
}  // namespace swerve
