// The discrete map: RK4 converges at order 4 (halving dt cuts the error ~16x) and Euler at order 1,
// for the state and for the wear quadrature; substeps equal smaller steps; the wear integral of a
// constant-rate motion is rate x dt; bad arguments return a status.
#include "swerve/models/integrators.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "support/model_fixtures.hpp"

namespace swerve {
namespace {

using Vector = Eigen::VectorXd;

// Soft tires (B = 1) keep the slip dynamics slow (~0.1 s) so the asymptotic regime is reachable.
VehicleParams soft_vehicle() {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.8, 0.6, 0.1));
  params.tire.longitudinal.b = 1.0;
  params.tire.lateral.b = 1.0;
  return params;
}

void maneuver(const VehicleModel<double>& model, Vector* x, Vector* u) {
  *x = Vector::Zero(model.state_size());
  *u = Vector::Zero(model.input_size());
  (*x)(StateIndex::kVx) = 0.8;
  (*x)(StateIndex::kVy) = 0.1;
  (*x)(StateIndex::kYawRate) = 0.2;
  for (int i = 0; i < model.modules(); ++i) {
    (*x)(StateIndex::steering(i)) = 0.1 * i;
    (*u)(InputIndex::steering_rate(i)) = 0.5 - 0.3 * i;
    (*u)(InputIndex::wheel_speed(i)) = 9.0 + i;
  }
}

struct Errors {
  double state;
  double wear;
};

Errors errors_at(const DiscreteDynamics<double>& dynamics, const Vector& x, const Vector& u, int substeps,
                 const Vector& x_ref, double wear_ref) {
  Vector next(x.size());
  double wear = 0.0;
  EXPECT_EQ(dynamics.step(x, u, 0.4, substeps, next, &wear), ModelStatus::kOk);
  return {(next - x_ref).norm(), std::abs(wear - wear_ref)};
}

void expect_order(IntegratorMethod method, double order, double tolerance) {
  const VehicleModel<double> model(soft_vehicle(), Fidelity::kIdeal);
  const DiscreteDynamics<double> dynamics(model, method);
  const DiscreteDynamics<double> reference(model, IntegratorMethod::kRk4);
  Vector x;
  Vector u;
  maneuver(model, &x, &u);
  Vector x_ref(model.state_size());
  double wear_ref = 0.0;
  ASSERT_EQ(reference.step(x, u, 0.4, 8192, x_ref, &wear_ref), ModelStatus::kOk);
  ASSERT_GT(wear_ref, 0.0);
  const int base = method == IntegratorMethod::kRk4 ? 16 : 256;
  const Errors coarse = errors_at(dynamics, x, u, base, x_ref, wear_ref);
  const Errors fine = errors_at(dynamics, x, u, 2 * base, x_ref, wear_ref);
  const Errors finer = errors_at(dynamics, x, u, 4 * base, x_ref, wear_ref);
  const double expected = std::pow(2.0, order);
  EXPECT_NEAR(coarse.state / fine.state, expected, tolerance * expected) << to_string(method);
  EXPECT_NEAR(fine.state / finer.state, expected, tolerance * expected) << to_string(method);
  EXPECT_NEAR(coarse.wear / fine.wear, expected, tolerance * expected) << to_string(method) << " wear";
  EXPECT_NEAR(fine.wear / finer.wear, expected, tolerance * expected) << to_string(method) << " wear";
}

TEST(DiscreteDynamics, Rk4ConvergesAtOrderFour) { expect_order(IntegratorMethod::kRk4, 4.0, 0.25); }

TEST(DiscreteDynamics, EulerConvergesAtOrderOne) { expect_order(IntegratorMethod::kEuler, 1.0, 0.1); }

TEST(DiscreteDynamics, SubstepsEqualRepeatedSmallerSteps) {
  const VehicleModel<double> model(testing::make_params(6), Fidelity::kIdeal);
  const DiscreteDynamics<double> dynamics(model);
  Vector x;
  Vector u;
  maneuver(model, &x, &u);
  Vector one(model.state_size());
  double wear_one = 0.0;
  std::vector<double> modules_one(6);
  ASSERT_EQ(dynamics.step(x, u, 0.05, 5, one, &wear_one, modules_one.data()), ModelStatus::kOk);
  Vector y = x;
  Vector next(model.state_size());
  double wear_sum = 0.0;
  for (int k = 0; k < 5; ++k) {
    double w = 0.0;
    ASSERT_EQ(dynamics.step(y, u, 0.01, 1, next, &w), ModelStatus::kOk);
    wear_sum += w;
    y = next;
  }
  EXPECT_NEAR((one - y).norm(), 0.0, 1e-12);
  EXPECT_NEAR(wear_one, wear_sum, 1e-12 * wear_sum);
  double module_sum = 0.0;
  for (double w : modules_one) {
    EXPECT_GE(w, 0.0);
    module_sum += w;
  }
  EXPECT_NEAR(module_sum, wear_one, 1e-12 * wear_one);
}

TEST(DiscreteDynamics, WearOfASteadyMotionIsRateTimesDt) {
  // Front wheels drive forward, rear wheels backward, all at rest: forces and moments cancel by
  // symmetry, the body stays at rest and every wheel slips at a constant rate, so the quadrature
  // must return exactly rate x dt.
  const VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.8, 0.6, 0.1));
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  const DiscreteDynamics<double> dynamics(model);
  const Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  for (int i = 0; i < 4; ++i) u(InputIndex::wheel_speed(i)) = i < 2 ? 5.0 : -5.0;
  Vector x_dot(model.state_size());
  double rate = 0.0;
  ASSERT_EQ(model.derivative(x, u, x_dot, nullptr, &rate), ModelStatus::kOk);
  ASSERT_GT(rate, 0.0);
  EXPECT_NEAR(x_dot.norm(), 0.0, 1e-9);
  Vector next(model.state_size());
  double wear = 0.0;
  ASSERT_EQ(dynamics.step(x, u, 0.05, 2, next, &wear), ModelStatus::kOk);
  EXPECT_NEAR(wear, rate * 0.05, 1e-12 * rate);
  // Four equal wheels: 0.5 m/s tread speed against the ground at rest, kappa = 0.5 / mean speed.
  const double eps = params.tire.slip_speed_epsilon;
  const double kappa = 0.5 / (0.5 * (eps + std::sqrt(0.25 + eps * eps)));
  const double fx = MagicFormulaTire<double>(params.tire).pure_longitudinal(kappa, params.mass * params.gravity / 4);
  EXPECT_NEAR(rate, 4.0 * fx * 0.5, 1e-9 * rate);
}

TEST(DiscreteDynamics, BadArgumentsAndNonFiniteValuesReturnAStatus) {
  const VehicleModel<double> model(testing::make_params(4), Fidelity::kIdeal);
  const DiscreteDynamics<double> dynamics(model);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  Vector next(model.state_size());
  EXPECT_EQ(dynamics.step(x, u, 0.0, 1, next), ModelStatus::kInvalidArgument);
  EXPECT_EQ(dynamics.step(x, u, 0.05, 0, next), ModelStatus::kInvalidArgument);
  EXPECT_EQ(dynamics.step(x, u, std::numeric_limits<double>::quiet_NaN(), 1, next), ModelStatus::kInvalidArgument);
  u(0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(dynamics.step(x, u, 0.05, 1, next), ModelStatus::kNonFiniteInput);
  EXPECT_TRUE(next.array().isNaN().all());
  u(0) = 0.0;
  x(0) = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(dynamics.step(x, u, 0.05, 1, next), ModelStatus::kNonFiniteState);
  EXPECT_STREQ(to_string(IntegratorMethod::kRk4), "rk4");
}

}  // namespace
}  // namespace swerve
