// The ideal model's linearisation per module (ModelLinearisation) against the model's full Jet
// Jacobian (DynamicsJacobian::continuous, one direction per state and input) and against central
// differences of each module's drive force; VehicleModel::acceleration_per_module_force against
// the model's own response to one module's steering angle.
#include "swerve/models/model_linearisation.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/model_fixtures.hpp"
#include "swerve/models/dynamics_jacobian.hpp"

namespace swerve {
namespace {

using testing::make_caster_params;
using testing::make_params;

// An off-centre CoM (so the yaw moment moves vx_dot and vy_dot too), turning, its modules off
// their rolling angles and speeds.
VehicleParams off_centre_vehicle() {
  VehicleParams params = make_params(6);
  params.center_of_mass_body = {0.07, -0.04};
  return params;
}

void turning_point(const VehicleModel<double>& model, Eigen::VectorXd* x, Eigen::VectorXd* u) {
  const int n = model.modules();
  *x = Eigen::VectorXd::Zero(model.state_size());
  *u = Eigen::VectorXd::Zero(model.input_size());
  (*x)[StateIndex::kPsi] = 0.3;
  x->segment<3>(StateIndex::kVx) << 0.8, 0.12, 0.35;
  const double radius = model.params().layout.wheel_radius();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = model.params().layout.position_body(i);
    const Eigen::Vector2d v(0.8 - 0.35 * p.y(), 0.12 + 0.35 * p.x());
    (*x)[StateIndex::steering(i)] = std::atan2(v.y(), v.x()) + 0.03 * (i % 3 - 1);
    (*u)[InputIndex::steering_rate(i)] = 0.2 * (i % 2 == 0 ? 1.0 : -1.0);
    (*u)[InputIndex::wheel_speed(i)] = v.norm() / radius * (1.0 + 0.02 * (i - 2));
  }
}

void expect_partials_match_the_full_jacobian(const VehicleParams& params) {
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Eigen::VectorXd x, u;
  turning_point(model, &x, &u);
  const int n = model.modules();
  const int nx = model.state_size();
  const int nu = model.input_size();

  DynamicsJacobian full(params, Fidelity::kIdeal, IntegratorMethod::kRk4);
  Eigen::VectorXd x_dot(nx), wear_gradient(nx + nu);
  Eigen::MatrixXd a(nx, nx), b(nx, nu);
  double wear = 0.0;
  ASSERT_EQ(full.continuous(x, u, x_dot, a, b, &wear, wear_gradient.data()), ModelStatus::kOk);

  const ModelLinearisation linearisation(params);
  ModelLinearisation::Data data(linearisation);
  ModelLinearisation::Point point = linearisation.make_point();
  ASSERT_TRUE(linearisation.linearise(data, x, u, &point));

  constexpr double kTolerance = 1e-10;
  EXPECT_NEAR(point.wear_rate, wear, kTolerance * (1.0 + std::abs(wear)));
  for (int row = 0; row < 3; ++row) {
    const int state_row = StateIndex::kVx + row;
    EXPECT_NEAR(point.acceleration[row], x_dot[state_row], kTolerance);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(point.acceleration_per_twist(row, j), a(state_row, StateIndex::kVx + j),
                  kTolerance * (1.0 + std::abs(a(state_row, StateIndex::kVx + j))));
    }
    for (int i = 0; i < n; ++i) {
      const double per_steering = a(state_row, StateIndex::steering(i));
      const double per_wheel = b(state_row, InputIndex::wheel_speed(i));
      EXPECT_NEAR(point.acceleration_per_steering(row, i), per_steering,
                  kTolerance * (1.0 + std::abs(per_steering)))
          << "row " << row << ", module " << i;
      EXPECT_NEAR(point.acceleration_per_wheel_speed(row, i), per_wheel,
                  kTolerance * (1.0 + std::abs(per_wheel)))
          << "row " << row << ", module " << i;
      // What the colouring rests on: the forces do not see the steering rate, nor the pose.
      EXPECT_EQ(b(state_row, InputIndex::steering_rate(i)), 0.0);
    }
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a(state_row, k), 0.0);
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(point.wear_rate_per_twist[j], wear_gradient[StateIndex::kVx + j],
                kTolerance * (1.0 + std::abs(wear_gradient[StateIndex::kVx + j])));
  }
  for (int i = 0; i < n; ++i) {
    const double per_steering = wear_gradient[StateIndex::steering(i)];
    const double per_wheel = wear_gradient[nx + InputIndex::wheel_speed(i)];
    EXPECT_NEAR(point.wear_rate_per_steering[i], per_steering, kTolerance * (1.0 + std::abs(per_steering)));
    EXPECT_NEAR(point.wear_rate_per_wheel_speed[i], per_wheel, kTolerance * (1.0 + std::abs(per_wheel)));
  }
}

TEST(ModelLinearisation, ItsPartialsAreTheFullJetJacobiansOfAccelerationAndWearWithAnOffCentreMass) {
  expect_partials_match_the_full_jacobian(off_centre_vehicle());
}

TEST(ModelLinearisation, ItsPartialsAreTheFullJetJacobiansOnAVehicleWithACaster) {
  expect_partials_match_the_full_jacobian(make_caster_params());
}

TEST(ModelLinearisation, EachModulesDriveForcePartialsAreCentralDifferencesOfThatForce) {
  const VehicleParams params = off_centre_vehicle();
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Eigen::VectorXd x, u;
  turning_point(model, &x, &u);
  const int n = model.modules();
  const ModelLinearisation linearisation(params);
  ModelLinearisation::Data data(linearisation);
  ModelLinearisation::Point point = linearisation.make_point();
  ASSERT_TRUE(linearisation.linearise(data, x, u, &point));

  std::vector<ModuleDiagnostics<double>> plus(static_cast<std::size_t>(n)),
      minus(static_cast<std::size_t>(n));
  Eigen::VectorXd x_dot(model.state_size());
  ASSERT_EQ(model.derivative(x, u, x_dot, plus.data()), ModelStatus::kOk);
  for (int i = 0; i < n; ++i)
    EXPECT_NEAR(point.drive_force[i], plus[static_cast<std::size_t>(i)].fx_wheel, 1e-9);
  constexpr double kH = 1e-6;
  for (int i = 0; i < n; ++i) {
    // Module i's own directions: vx, vy, r, its steering angle, its wheel speed.
    const int state_of[4] = {StateIndex::kVx, StateIndex::kVy, StateIndex::kYawRate, StateIndex::steering(i)};
    for (int direction = 0; direction < 5; ++direction) {
      Eigen::VectorXd xp = x, xm = x, up = u, um = u;
      if (direction < 4) {
        xp[state_of[direction]] += kH;
        xm[state_of[direction]] -= kH;
      } else {
        up[InputIndex::wheel_speed(i)] += kH;
        um[InputIndex::wheel_speed(i)] -= kH;
      }
      ASSERT_EQ(model.derivative(xp, up, x_dot, plus.data()), ModelStatus::kOk);
      ASSERT_EQ(model.derivative(xm, um, x_dot, minus.data()), ModelStatus::kOk);
      const auto k = static_cast<std::size_t>(i);
      const double difference = (plus[k].fx_wheel - minus[k].fx_wheel) / (2.0 * kH);
      EXPECT_NEAR(point.drive_force_partials(i, direction), difference, 1e-4 * (1.0 + std::abs(difference)))
          << "module " << i << ", direction " << direction;
    }
  }
}

TEST(ModelLinearisation, AccelerationPerModuleForceIsTheModelsOwnResponseToThatModulesSteeringAndNoOtherModuleSeesIt) {
  const VehicleParams params = off_centre_vehicle();
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  const VehicleModel<ModelJet> jet_model(params, Fidelity::kIdeal);
  Eigen::VectorXd x, u;
  turning_point(model, &x, &u);
  const int module = 4;
  VehicleModel<ModelJet>::Vector x_jet(model.state_size()), u_jet(model.input_size()),
      x_dot(model.state_size());
  for (Eigen::Index k = 0; k < x.size(); ++k) x_jet[k] = ModelJet(x[k]);
  for (Eigen::Index k = 0; k < u.size(); ++k) u_jet[k] = ModelJet(u[k]);
  x_jet[StateIndex::steering(module)].v[0] = 1.0;
  u_jet[InputIndex::wheel_speed(module)].v[1] = 1.0;
  std::vector<ModuleDiagnostics<ModelJet>> diagnostics(static_cast<std::size_t>(model.modules()));
  ASSERT_EQ(jet_model.derivative(x_jet, u_jet, x_dot, diagnostics.data()), ModelStatus::kOk);
  const ModuleDiagnostics<ModelJet>& moved = diagnostics[static_cast<std::size_t>(module)];
  const Eigen::Vector2d force_change(moved.fx_body.v[0], moved.fy_body.v[0]);
  ASSERT_GT(force_change.norm(), 1.0);  // the steering does move the force
  const Eigen::Vector3d expected = model.acceleration_per_module_force(module) * force_change;
  for (int row = 0; row < 3; ++row) {
    EXPECT_NEAR(x_dot[StateIndex::kVx + row].v[0], expected[row], 1e-12 * (1.0 + std::abs(expected[row])));
  }
  // What the colouring rests on: the other modules' forces and wear do not see this module's
  // steering angle or wheel speed at all.
  for (int other = 0; other < model.modules(); ++other) {
    if (other == module) continue;
    const ModuleDiagnostics<ModelJet>& still = diagnostics[static_cast<std::size_t>(other)];
    for (int direction = 0; direction < 2; ++direction) {
      EXPECT_EQ(still.fx_wheel.v[direction], 0.0) << "module " << other;
      EXPECT_EQ(still.fx_body.v[direction], 0.0) << "module " << other;
      EXPECT_EQ(still.fy_body.v[direction], 0.0) << "module " << other;
      EXPECT_EQ(still.wear_rate.v[direction], 0.0) << "module " << other;
    }
  }
}

TEST(ModelLinearisation, RefusesAStateOrInputOfTheWrongSizeOrNotFinite) {
  const VehicleParams params = make_params(4);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Eigen::VectorXd x, u;
  turning_point(model, &x, &u);
  const ModelLinearisation linearisation(params);
  ModelLinearisation::Data data(linearisation);
  ModelLinearisation::Point point = linearisation.make_point();
  EXPECT_TRUE(linearisation.linearise(data, x, u, &point));
  EXPECT_FALSE(linearisation.linearise(data, x.head(x.size() - 1), u, &point));
  EXPECT_FALSE(linearisation.linearise(data, x, u.head(u.size() - 1), &point));
  Eigen::VectorXd bad = x;
  bad[StateIndex::kVy] = std::nan("");
  EXPECT_FALSE(linearisation.linearise(data, bad, u, &point));
  const ModelLinearisation other(make_params(6));
  ModelLinearisation::Point other_point = other.make_point();
  EXPECT_FALSE(linearisation.linearise(data, x, u, &other_point));
}

}  // namespace
}  // namespace swerve
