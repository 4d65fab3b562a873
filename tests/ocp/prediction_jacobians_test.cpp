// The prediction models' exact Jacobians (ceres::Jet through the semi-implicit step, with the
// implicit-function derivative of its Newton solve) against central finite differences of step(),
// on seeded random states: cruising, slow (the five-substep regime) and at standstill.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "support/model_fixtures.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

constexpr double kDt = 0.05;

struct Linearization {
  Eigen::VectorXd x_next, wear_gradient;
  Eigen::MatrixXd a, b;
  double wear = 0.0;
};

Linearization finite_differences(const PredictionModel& model, const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
  const int nx = model.state_size(), nu = model.input_size();
  Linearization fd{Eigen::VectorXd(nx), Eigen::VectorXd(nx + nu), Eigen::MatrixXd(nx, nx), Eigen::MatrixXd(nx, nu)};
  EXPECT_TRUE(testing::step_once(model, x, u, kDt, fd.x_next, &fd.wear));
  Eigen::VectorXd plus(nx), minus(nx);
  for (int j = 0; j < nx + nu; ++j) {
    Eigen::VectorXd xp = x, xm = x, up = u, um = u;
    const double h = 1e-6 * (1.0 + std::abs(j < nx ? x[j] : u[j - nx]));
    if (j < nx) {
      xp[j] += h;
      xm[j] -= h;
    } else {
      up[j - nx] += h;
      um[j - nx] -= h;
    }
    double wear_plus = 0.0, wear_minus = 0.0;
    EXPECT_TRUE(testing::step_once(model, xp, up, kDt, plus, &wear_plus));
    EXPECT_TRUE(testing::step_once(model, xm, um, kDt, minus, &wear_minus));
    Eigen::VectorXd column = (plus - minus) / (2.0 * h);
    column[StateIndex::kPsi] = wrap_angle(plus[StateIndex::kPsi] - minus[StateIndex::kPsi]) / (2.0 * h);
    (j < nx ? fd.a.col(j) : fd.b.col(j - nx)) = column;
    fd.wear_gradient[j] = (wear_plus - wear_minus) / (2.0 * h);
  }
  return fd;
}

// Largest entry-wise error relative to max(1, |entry|).
double relative_error(const Eigen::MatrixXd& exact, const Eigen::MatrixXd& fd) {
  return ((exact - fd).array().abs() / fd.array().abs().max(1.0)).maxCoeff();
}

void expect_jacobians_match(const PredictionModel& model, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                            double tolerance, const char* label) {
  const int nx = model.state_size(), nu = model.input_size();
  Linearization exact{Eigen::VectorXd(nx), Eigen::VectorXd(nx + nu), Eigen::MatrixXd(nx, nx), Eigen::MatrixXd(nx, nu)};
  ASSERT_TRUE(testing::step_jacobians_once(model, x, u, kDt, exact.x_next, exact.a, exact.b, &exact.wear, exact.wear_gradient)) << label;
  ASSERT_TRUE(exact.a.allFinite() && exact.b.allFinite() && exact.wear_gradient.allFinite()) << label;
  const Linearization fd = finite_differences(model, x, u);
  EXPECT_LT((exact.x_next - fd.x_next).cwiseAbs().maxCoeff(), 1e-12) << label << ": the values must be step()'s";
  EXPECT_NEAR(exact.wear, fd.wear, 1e-12 * (1.0 + fd.wear)) << label;
  const double error_a = relative_error(exact.a, fd.a), error_b = relative_error(exact.b, fd.b);
  // The wear gradient's scale is the wear's (1e-3 J per step): relative to its largest entry, and
  // to no less than 1e-6 (at standstill the central differences of the end-of-step wear rate are
  // 1e-11 of rounding where the exact gradient is 0).
  const double wear_scale = std::max(1e-6, fd.wear_gradient.cwiseAbs().maxCoeff());
  const double error_wear = (exact.wear_gradient - fd.wear_gradient).cwiseAbs().maxCoeff() / wear_scale;
  std::printf("[          ] %-28s |dF/dx| err %.1e  |dF/du| err %.1e  |dW| err %.1e (|dW| %.1e)\n", label, error_a,
              error_b, error_wear, wear_scale);
  EXPECT_LT(error_a, tolerance) << label << "\nexact a\n" << exact.a << "\nfd a\n" << fd.a;
  EXPECT_LT(error_b, tolerance) << label << "\nexact b\n" << exact.b << "\nfd b\n" << fd.b;
  EXPECT_LT(error_wear, 10 * tolerance) << label << "\nexact\n" << exact.wear_gradient.transpose() << "\nfd\n"
                                        << fd.wear_gradient.transpose();
}

VehicleParams four_wheel() {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
  params.mass = 160.0;
  params.yaw_inertia = 8.0;
  return params;
}

// A state moving with `twist`, wheels pointing `misalignment` away from their contact velocity.
Eigen::VectorXd moving_state(const VehicleParams& params, const Eigen::Vector3d& twist, double misalignment,
                             double heading) {
  const int n = params.layout.size();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(StateIndex::prefix_size(n));
  x << 1.0, -2.0, heading, twist, Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = params.layout.position_body(i);
    x[StateIndex::steering(i)] =
        std::atan2(twist.y() + twist.z() * p.x(), twist.x() - twist.z() * p.y()) + misalignment * (i % 2 ? 1 : -1);
  }
  return x;
}

class PredictionJacobians : public ::testing::Test {
 protected:
  VehicleParams params = four_wheel();
  TwistPredictionModel twist_model{params};
  std::mt19937 random{20261127};
  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(random); }
};

TEST_F(PredictionJacobians, TwistInputsMatchFiniteDifferencesWhileCruising) {
  for (int trial = 0; trial < 6; ++trial) {
    const Eigen::Vector3d twist(uniform(0.4, 1.0), uniform(-0.2, 0.2), uniform(-0.4, 0.4));
    const Eigen::VectorXd x = moving_state(params, twist, uniform(0.0, 0.05), uniform(-3.0, 3.0));
    const Eigen::Vector3d command = twist + Eigen::Vector3d(uniform(-0.1, 0.1), uniform(-0.1, 0.1), uniform(-0.1, 0.1));
    expect_jacobians_match(twist_model, x, command, 1e-5, "twist, cruising");
  }
}

TEST_F(PredictionJacobians, TwistInputsMatchFiniteDifferencesInSlowMotionAndStartUp) {
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::Vector3d twist(uniform(0.01, 0.05), uniform(-0.01, 0.01), uniform(-0.02, 0.02));
    const Eigen::VectorXd x = moving_state(params, twist, uniform(0.0, 0.1), uniform(-3.0, 3.0));
    const Eigen::Vector3d command(uniform(0.02, 0.1), uniform(-0.05, 0.05), uniform(-0.05, 0.05));
    expect_jacobians_match(twist_model, x, command, 1e-5, "twist, slow");
  }
}

TEST_F(PredictionJacobians, AreFiniteAtStandstill) {
  // At rest with no command every module holds its angle: no NaN from atan2(0, 0) or hypot(0, 0).
  const Eigen::VectorXd x = moving_state(params, Eigen::Vector3d::Zero(), 0.0, 0.0);
  expect_jacobians_match(twist_model, x, Eigen::Vector3d::Zero(), 1e-5, "twist, standstill");
  expect_jacobians_match(twist_model, x, Eigen::Vector3d(0.2, 0.0, 0.0), 1e-5, "twist, start from rest");
}

TEST_F(PredictionJacobians, ModuleInputsMatchFiniteDifferences) {
  const VehiclePredictionModel& modules = twist_model.module_model();
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::Vector3d twist(uniform(0.3, 0.8), uniform(-0.2, 0.2), uniform(-0.3, 0.3));
    const Eigen::VectorXd x = moving_state(params, twist, uniform(0.0, 0.05), uniform(-3.0, 3.0));
    Eigen::VectorXd u(modules.input_size());
    twist_model.module_inputs(x, twist, kDt, u);
    for (int k = 0; k < u.size(); ++k) u[k] += uniform(-0.2, 0.2);
    expect_jacobians_match(modules, x, u, 1e-5, "module rates, cruising");
  }
}

TEST_F(PredictionJacobians, MatchOnTheTenModulePaperVehicleLayout) {
  const VehicleParams ten = testing::make_params(ModuleLayout::multi_axle(5, 0.8, 0.7, 0.1));
  const TwistPredictionModel model(ten);
  const Eigen::Vector3d twist(0.8, 0.1, 0.2);
  expect_jacobians_match(model, moving_state(ten, twist, 0.02, 0.5), Eigen::Vector3d(0.85, 0.05, 0.25), 1e-5,
                         "twist, 10 modules");
}

TEST_F(PredictionJacobians, MatchWithTheWheelSpeedsAsLaggedStates) {
  // drive_lag: the state carries the wheel speeds (x[10..13]). Wheels behind their commands by
  // amounts that put the drives' clamp on, off, and in between over the step.
  PredictionOptions options;
  options.drive_lag = true;
  const TwistPredictionModel lagged(params, options);
  ASSERT_EQ(lagged.state_size(), StateIndex::prefix_size(4) + 4);
  for (int trial = 0; trial < 4; ++trial) {
    const Eigen::Vector3d twist(uniform(0.3, 0.8), uniform(-0.2, 0.2), uniform(-0.3, 0.3));
    Eigen::VectorXd x(lagged.state_size());
    x << moving_state(params, twist, uniform(0.0, 0.05), uniform(-3.0, 3.0)), Eigen::VectorXd::Zero(4);
    for (int i = 0; i < 4; ++i) x[StateIndex::prefix_size(4) + i] = twist.x() / 0.1 + uniform(-3.0, 3.0);
    const Eigen::Vector3d command = twist + Eigen::Vector3d(uniform(-0.1, 0.1), uniform(-0.1, 0.1), uniform(-0.1, 0.1));
    expect_jacobians_match(lagged, x, command, 1e-5, "twist, lagged drives");
  }
}

TEST_F(PredictionJacobians, MatchWithTheWheelSpeedsAndSteeringRatesAsLaggedStates) {
  // drive_lag and steering_lag: x[10..13] the wheel speeds, x[14..17] the steering rates, each
  // followed through its lag substep by substep (five under 0.25 m/s, one above).
  PredictionOptions options;
  options.drive_lag = true;
  options.steering_lag = true;
  const TwistPredictionModel lagged(params, options);
  ASSERT_EQ(lagged.state_size(), StateIndex::prefix_size(4) + 8);
  for (int trial = 0; trial < 4; ++trial) {
    const double speed = trial < 2 ? uniform(0.3, 0.8) : uniform(0.05, 0.2);
    const Eigen::Vector3d twist(speed, uniform(-0.1, 0.1), uniform(-0.2, 0.2));
    Eigen::VectorXd x(lagged.state_size());
    x << moving_state(params, twist, uniform(0.0, 0.05), uniform(-3.0, 3.0)), Eigen::VectorXd::Zero(8);
    for (int i = 0; i < 4; ++i) {
      x[StateIndex::prefix_size(4) + i] = twist.x() / 0.1 + uniform(-1.0, 1.0);
      x[StateIndex::prefix_size(4) + 4 + i] = uniform(-1.0, 1.0);
    }
    const Eigen::Vector3d command =
        twist + Eigen::Vector3d(uniform(-0.05, 0.05), uniform(-0.05, 0.05), uniform(-0.1, 0.1));
    expect_jacobians_match(lagged, x, command, 1e-5,
                           trial < 2 ? "twist, lagged actuators" : "twist, lagged actuators, slow");
  }
}

TEST_F(PredictionJacobians, RejectWrongSizesAndNonFiniteInput) {
  const int nx = twist_model.state_size();
  Eigen::VectorXd x = moving_state(params, Eigen::Vector3d(0.5, 0.0, 0.0), 0.0, 0.0), x_next(nx), gradient(nx + 3);
  Eigen::MatrixXd a(nx, nx), b(nx, 3);
  double wear = 0.0;
  EXPECT_FALSE(testing::step_jacobians_once(twist_model, x, Eigen::Vector2d(0.5, 0.0), kDt, x_next, a, b, &wear, gradient));
  Eigen::MatrixXd b_wrong(nx, 2);
  EXPECT_FALSE(testing::step_jacobians_once(twist_model, x, Eigen::Vector3d(0.5, 0, 0), kDt, x_next, a, b_wrong, &wear, gradient));
  EXPECT_FALSE(testing::step_jacobians_once(twist_model, x, Eigen::Vector3d(0.5, 0, 0), -kDt, x_next, a, b, &wear, gradient));
  x[0] = std::nan("");
  EXPECT_FALSE(testing::step_jacobians_once(twist_model, x, Eigen::Vector3d(0.5, 0, 0), kDt, x_next, a, b, &wear, gradient));
}

}  // namespace
}  // namespace swerve
