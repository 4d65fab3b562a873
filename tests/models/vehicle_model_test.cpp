// Dynamic vehicle model invariants for 2, 3, 4, 6, 8 and 16 modules: straight-line rolling, spin in
// place, mirror symmetry, momentum conservation without tire forces, steady cornering with
// sum F = m v^2 / R, the caster robot, plant fidelity states, and the NaN/inf status.
#include "swerve/models/vehicle_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "support/model_fixtures.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/magic_formula_tire.hpp"

namespace swerve {
namespace {

using Vector = Eigen::VectorXd;

class VehicleModelLayouts : public ::testing::TestWithParam<int> {
 protected:
  testing::NamedLayout named() const { return testing::test_layouts()[static_cast<std::size_t>(GetParam())]; }
};

std::string layout_name(const ::testing::TestParamInfo<int>& info) {
  return testing::test_layouts()[static_cast<std::size_t>(info.param)].name;
}

// Wheels aligned with and rolling at the contact velocity of body twist (vx, vy, r).
void set_rolling(const ModuleLayout& layout, double vx, double vy, double r, Vector* x, Vector* u) {
  (*x)(StateIndex::kVx) = vx;
  (*x)(StateIndex::kVy) = vy;
  (*x)(StateIndex::kYawRate) = r;
  for (int i = 0; i < layout.size(); ++i) {
    const Eigen::Vector2d& p = layout.position_body(i);
    const double cvx = vx - r * p.y();
    const double cvy = vy + r * p.x();
    (*x)(StateIndex::steering(i)) = std::atan2(cvy, cvx);
    (*u)(InputIndex::wheel_speed(i)) = std::hypot(cvx, cvy) / layout.wheel_radius();
  }
}

TEST_P(VehicleModelLayouts, StraightLineWithAlignedWheelsIsSteady) {
  const auto layout = named().layout;
  const VehicleModel<double> model(testing::make_params(layout), Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  x(StateIndex::kPsi) = 0.3;
  set_rolling(layout, 1.2, 0.0, 0.0, &x, &u);
  Vector x_dot(model.state_size());
  std::vector<ModuleDiagnostics<double>> diag(static_cast<std::size_t>(model.modules()));
  ASSERT_EQ(model.derivative(x, u, x_dot, diag.data()), ModelStatus::kOk);
  EXPECT_NEAR(x_dot(StateIndex::kX), 1.2 * std::cos(0.3), 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kY), 1.2 * std::sin(0.3), 1e-12);
  EXPECT_EQ(x_dot(StateIndex::kPsi), 0.0);
  EXPECT_NEAR(x_dot(StateIndex::kVx), 0.0, 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kVy), 0.0, 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-12);
  for (const auto& d : diag) {
    EXPECT_NEAR(d.fy_wheel, 0.0, 1e-9);
    EXPECT_NEAR(d.fx_wheel, 0.0, 1e-9);
    EXPECT_NEAR(d.wear_rate, 0.0, 1e-12);
  }
  // Driving faster than the ground accelerates the body forward without yaw or side force.
  for (int i = 0; i < model.modules(); ++i) u(InputIndex::wheel_speed(i)) *= 1.05;
  ASSERT_EQ(model.derivative(x, u, x_dot, diag.data()), ModelStatus::kOk);
  EXPECT_GT(x_dot(StateIndex::kVx), 0.0);
  EXPECT_NEAR(x_dot(StateIndex::kVy), 0.0, 1e-9);
  EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-9);
  for (const auto& d : diag) EXPECT_GT(d.wear_rate, 0.0);
}

TEST_P(VehicleModelLayouts, SpinInPlaceWithTangentWheelsDoesNotTranslate) {
  const auto layout = named().layout;
  const VehicleModel<double> model(testing::make_params(layout), Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  set_rolling(layout, 0.0, 0.0, 0.8, &x, &u);
  Vector x_dot(model.state_size());
  ASSERT_EQ(model.derivative(x, u, x_dot), ModelStatus::kOk);
  EXPECT_NEAR(x_dot(StateIndex::kVx), 0.0, 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kVy), 0.0, 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-12);
  // Integrate 2 s: the origin (the geometric centre) stays put while psi advances 1.6 rad.
  // (Substeps keep RK4 inside its stability region of the stiff slip dynamics.)
  const DiscreteDynamics<double> dynamics(model);
  const int substeps = model.recommended_substeps(0.01, 0.8 * 0.3);
  Vector next(model.state_size());
  for (int k = 0; k < 200; ++k) {
    ASSERT_EQ(dynamics.step(x, u, 0.01, substeps, next), ModelStatus::kOk);
    x = next;
  }
  EXPECT_NEAR(x(StateIndex::kX), 0.0, 1e-9);
  EXPECT_NEAR(x(StateIndex::kY), 0.0, 1e-9);
  EXPECT_NEAR(x(StateIndex::kPsi), 1.6, 1e-9);
}

// Index of the module mirrored across the body x axis.
int mirror_of(const ModuleLayout& layout, int i) {
  const Eigen::Vector2d target(layout.position_body(i).x(), -layout.position_body(i).y());
  for (int j = 0; j < layout.size(); ++j) {
    if ((layout.position_body(j) - target).norm() < 1e-9) return j;
  }
  return -1;
}

TEST_P(VehicleModelLayouts, MirroredStateAndInputsGiveMirroredForces) {
  const auto layout = named().layout;
  const VehicleModel<double> model(testing::make_params(layout), Fidelity::kIdeal);
  const int n = model.modules();
  std::srand(7);
  Vector x = Vector::Random(model.state_size());
  Vector u = Vector::Random(model.input_size()) * 10.0;
  Vector xm = x;
  Vector um = u;
  xm(StateIndex::kY) = -x(StateIndex::kY);
  xm(StateIndex::kPsi) = -x(StateIndex::kPsi);
  xm(StateIndex::kVy) = -x(StateIndex::kVy);
  xm(StateIndex::kYawRate) = -x(StateIndex::kYawRate);
  for (int i = 0; i < n; ++i) {
    const int m = mirror_of(layout, i);
    ASSERT_GE(m, 0);
    xm(StateIndex::steering(m)) = -x(StateIndex::steering(i));
    um(InputIndex::steering_rate(m)) = -u(InputIndex::steering_rate(i));
    um(InputIndex::wheel_speed(m)) = u(InputIndex::wheel_speed(i));
  }
  Vector x_dot(model.state_size());
  Vector xm_dot(model.state_size());
  std::vector<ModuleDiagnostics<double>> d(static_cast<std::size_t>(n));
  std::vector<ModuleDiagnostics<double>> dm(static_cast<std::size_t>(n));
  ASSERT_EQ(model.derivative(x, u, x_dot, d.data()), ModelStatus::kOk);
  ASSERT_EQ(model.derivative(xm, um, xm_dot, dm.data()), ModelStatus::kOk);
  EXPECT_NEAR(xm_dot(StateIndex::kX), x_dot(StateIndex::kX), 1e-9);
  EXPECT_NEAR(xm_dot(StateIndex::kY), -x_dot(StateIndex::kY), 1e-9);
  EXPECT_NEAR(xm_dot(StateIndex::kVx), x_dot(StateIndex::kVx), 1e-9);
  EXPECT_NEAR(xm_dot(StateIndex::kVy), -x_dot(StateIndex::kVy), 1e-9);
  EXPECT_NEAR(xm_dot(StateIndex::kYawRate), -x_dot(StateIndex::kYawRate), 1e-9);
  for (int i = 0; i < n; ++i) {
    const auto& a = d[static_cast<std::size_t>(i)];
    const auto& b = dm[static_cast<std::size_t>(mirror_of(layout, i))];
    EXPECT_NEAR(b.fx_body, a.fx_body, 1e-9);
    EXPECT_NEAR(b.fy_body, -a.fy_body, 1e-9);
    EXPECT_NEAR(b.wear_rate, a.wear_rate, 1e-9);
  }
}

TEST_P(VehicleModelLayouts, WithoutTireForcesTheBodyKeepsItsMomentum) {
  // mu -> 0 removes every contact force: the CoM moves on a straight line at constant world
  // velocity and the yaw rate stays constant, whatever the steering does (CoM off the origin).
  VehicleParams params = testing::make_params(named().layout);
  params.tire.mu = 1e-14;
  params.center_of_mass_body = {0.0, 0.0};
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Constant(model.input_size(), 3.0);
  const double vx0 = 0.7;
  const double vy0 = -0.4;
  const double r0 = 0.9;
  x(StateIndex::kVx) = vx0;
  x(StateIndex::kVy) = vy0;
  x(StateIndex::kYawRate) = r0;
  const DiscreteDynamics<double> dynamics(model);
  Vector next(model.state_size());
  const double t_end = 2.0;
  for (int k = 0; k < 400; ++k) {
    ASSERT_EQ(dynamics.step(x, u, t_end / 400, 1, next), ModelStatus::kOk);
    x = next;
  }
  const double psi = x(StateIndex::kPsi);
  EXPECT_NEAR(psi, r0 * t_end, 1e-9);
  EXPECT_NEAR(x(StateIndex::kYawRate), r0, 1e-9);
  const double vxw = std::cos(psi) * x(StateIndex::kVx) - std::sin(psi) * x(StateIndex::kVy);
  const double vyw = std::sin(psi) * x(StateIndex::kVx) + std::cos(psi) * x(StateIndex::kVy);
  EXPECT_NEAR(vxw, vx0, 1e-8);
  EXPECT_NEAR(vyw, vy0, 1e-8);
  EXPECT_NEAR(x(StateIndex::kX), vx0 * t_end, 1e-8);
  EXPECT_NEAR(x(StateIndex::kY), vy0 * t_end, 1e-8);
}

TEST(VehicleModel, WithoutTireForcesAnOffsetCentreOfMassKeepsItsMomentum) {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(1.0, 0.6, 0.1));
  params.tire.mu = 1e-14;
  params.center_of_mass_body = {0.15, -0.05};
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  const Vector u = Vector::Zero(model.input_size());
  x(StateIndex::kVx) = 0.5;
  x(StateIndex::kVy) = 0.2;
  x(StateIndex::kYawRate) = -1.1;
  auto com_world_velocity = [&](const Vector& s) {
    const double psi = s(StateIndex::kPsi);
    const double r = s(StateIndex::kYawRate);
    const double vcx = s(StateIndex::kVx) - r * params.center_of_mass_body.y();
    const double vcy = s(StateIndex::kVy) + r * params.center_of_mass_body.x();
    return Eigen::Vector2d(std::cos(psi) * vcx - std::sin(psi) * vcy, std::sin(psi) * vcx + std::cos(psi) * vcy);
  };
  const Eigen::Vector2d v0 = com_world_velocity(x);
  const DiscreteDynamics<double> dynamics(model);
  Vector next(model.state_size());
  for (int k = 0; k < 300; ++k) {
    ASSERT_EQ(dynamics.step(x, u, 0.01, 1, next), ModelStatus::kOk);
    x = next;
  }
  EXPECT_NEAR((com_world_velocity(x) - v0).norm(), 0.0, 1e-8);
  EXPECT_NEAR(x(StateIndex::kYawRate), -1.1, 1e-9);
}

TEST_P(VehicleModelLayouts, SteadyCorneringCarriesMVSquaredOverR) {
  // Wheels set (and held) to the kinematic steering of a 4 m circle at 1 m/s and rolling at their
  // contact speeds; the vehicle drifts until the slip angles carry the centripetal load, then
  // circles steadily. At that steady state the contact forces sum to m v^2 / R towards the centre,
  // with v and R measured from the motion, and the yaw moment and tangential force vanish.
  const auto layout = named().layout;
  const VehicleParams params = testing::make_params(layout);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  set_rolling(layout, 1.0, 0.0, 1.0 / 4.0, &x, &u);
  const DiscreteDynamics<double> dynamics(model);
  Vector next(model.state_size());
  for (int k = 0; k < 3000; ++k) {
    ASSERT_EQ(dynamics.step(x, u, 0.002, 1, next), ModelStatus::kOk);
    x = next;
  }
  Vector x_dot(model.state_size());
  std::vector<ModuleDiagnostics<double>> diag(static_cast<std::size_t>(model.modules()));
  ASSERT_EQ(model.derivative(x, u, x_dot, diag.data()), ModelStatus::kOk);
  // Steady: body velocities no longer change.
  EXPECT_NEAR(x_dot(StateIndex::kVx), 0.0, 1e-6);
  EXPECT_NEAR(x_dot(StateIndex::kVy), 0.0, 1e-6);
  EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-6);
  const double vx = x(StateIndex::kVx);
  const double vy = x(StateIndex::kVy);
  const double r = x(StateIndex::kYawRate);
  const double v = std::hypot(vx, vy);
  const double radius = v / r;
  double fx = 0.0;
  double fy = 0.0;
  for (const auto& d : diag) {
    fx += d.fx_body;
    fy += d.fy_body;
  }
  // Component along the velocity ~ 0; normal component (left of the velocity) = m v^2 / R.
  const double f_tangential = (fx * vx + fy * vy) / v;
  const double f_normal = (-fx * vy + fy * vx) / v;
  const double expected = params.mass * v * v / radius;
  EXPECT_NEAR(f_normal, expected, 1e-4 * expected);
  EXPECT_NEAR(f_tangential, 0.0, 1e-4 * expected);
  EXPECT_GT(f_normal, 0.0);
  EXPECT_NEAR(radius, 4.0, 0.2);  // close to the commanded circle (tires are stiff)
  EXPECT_NEAR(v, 1.0, 0.05);
}

INSTANTIATE_TEST_SUITE_P(Layouts, VehicleModelLayouts, ::testing::Range(0, 6), layout_name);

TEST(VehicleModel, CasterRobotRollsWithRollingResistanceOnly) {
  const VehicleParams params = testing::make_caster_params();
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  set_rolling(params.layout, 1.0, 0.0, 0.0, &x, &u);
  Vector x_dot(model.state_size());
  ASSERT_EQ(model.derivative(x, u, x_dot), ModelStatus::kOk);
  // Caster force -c_rr Fz_c v / sqrt(v^2 + eps^2) on the x axis, through y = 0: no side force or yaw.
  const double fz_caster = model.static_normal_loads()[2];
  const double eps = params.tire.slip_speed_epsilon;
  EXPECT_NEAR(x_dot(StateIndex::kVx), -0.03 * fz_caster / std::sqrt(1.0 + eps * eps) / params.mass, 1e-12);
  EXPECT_NEAR(x_dot(StateIndex::kVy), 0.0, 1e-12);
  // Moment of the caster drag about the CoM: arm (x_c - c_x, 0) x (F, 0) = 0.
  EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-12);
}

TEST(VehicleModel, RecommendedSubstepsKeepRk4StableOnTheStiffSlipDynamics) {
  // The paper vehicle: tau = eps m / sum K = 0.05 * 800 / (10 * 0.8 * 784.8 * 19.5) ~ 0.33 ms at rest.
  VehicleParams params(ModuleLayout::multi_axle(5, 1.04, 1.69, 0.325));
  params.mass = 800.0;
  params.yaw_inertia = 2900.0;
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  EXPECT_NEAR(model.slip_time_constant(0.0), 0.05 * 800.0 / (10 * 0.8 * 784.8 * 19.5), 1e-9);
  EXPECT_NEAR(model.slip_time_constant(1.0), 20.0 * model.slip_time_constant(0.0), 1e-9);
  EXPECT_EQ(model.recommended_substeps(0.05, 1.0), 4);
  // At rest with a wheel nudged off rolling, the recommended RK4 step decays the slip; 4x that
  // step is unstable and grows.
  Vector x = Vector::Zero(model.state_size());
  const Vector u = Vector::Zero(model.input_size());
  x(StateIndex::kVx) = 1e-3;
  const DiscreteDynamics<double> dynamics(model);
  Vector next(model.state_size());
  const double h = 1.0 / model.recommended_substeps(1.0, 0.0);
  Vector y = x;
  for (int k = 0; k < 50; ++k) {
    ASSERT_EQ(dynamics.step(y, u, h, 1, next), ModelStatus::kOk);
    y = next;
  }
  EXPECT_LT(std::abs(y(StateIndex::kVx)), 1e-3);
  y = x;
  double largest = 0.0;
  for (int k = 0; k < 50; ++k) {
    ASSERT_EQ(dynamics.step(y, u, 4 * h, 1, next), ModelStatus::kOk);
    y = next;
    largest = std::max(largest, std::abs(y(StateIndex::kVx)));
  }
  EXPECT_GT(largest, 2e-3);  // grew (until the tire saturates) instead of decaying
}

// The Newton solve over the body twist hands the model each module's steering cos and sin once per
// solve: given those of the state's own angles, the result is derivative()'s bit for bit; given
// another angle's, it is derivative() at that angle (so the given values are what is used).
TEST(VehicleModel, DerivativeAtGivenSteeringTrigIsTheDerivativeAtThoseAngles) {
  const VehicleModel<double> model(testing::make_params(4), Fidelity::kIdeal);
  const int n = model.modules();
  Vector x = Vector::Zero(model.state_size());
  x(StateIndex::kVx) = 0.7;
  x(StateIndex::kVy) = -0.2;
  x(StateIndex::kYawRate) = 0.4;
  Vector u = Vector::Zero(model.input_size());
  std::vector<double> cos_delta(static_cast<std::size_t>(n)), sin_delta(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    x(StateIndex::steering(i)) = -0.3 + 0.25 * i;
    u(InputIndex::wheel_speed(i)) = 7.0 + 0.5 * i;
    u(InputIndex::steering_rate(i)) = 0.1 * i;
    cos_delta[static_cast<std::size_t>(i)] = std::cos(x(StateIndex::steering(i)));
    sin_delta[static_cast<std::size_t>(i)] = std::sin(x(StateIndex::steering(i)));
  }
  Vector expected(model.state_size()), given(model.state_size());
  double expected_wear = 0.0, given_wear = 0.0;
  ASSERT_EQ(model.derivative(x, u, expected, nullptr, &expected_wear), ModelStatus::kOk);
  ASSERT_EQ(model.derivative_at_steering(x, u, cos_delta.data(), sin_delta.data(), given, nullptr, &given_wear),
            ModelStatus::kOk);
  for (int k = 0; k < model.state_size(); ++k) EXPECT_EQ(given(k), expected(k)) << "row " << k;
  EXPECT_EQ(given_wear, expected_wear);

  Vector turned = x;
  turned(StateIndex::steering(2)) += 0.4;
  cos_delta[2] = std::cos(turned(StateIndex::steering(2)));
  sin_delta[2] = std::sin(turned(StateIndex::steering(2)));
  ASSERT_EQ(model.derivative(turned, u, expected), ModelStatus::kOk);
  ASSERT_EQ(model.derivative_at_steering(x, u, cos_delta.data(), sin_delta.data(), given, nullptr, nullptr),
            ModelStatus::kOk);
  for (int k = StateIndex::kVx; k <= StateIndex::kYawRate; ++k) EXPECT_EQ(given(k), expected(k)) << "row " << k;
  Vector original(model.state_size());
  ASSERT_EQ(model.derivative(x, u, original), ModelStatus::kOk);
  EXPECT_GT((given.segment<3>(StateIndex::kVx) - original.segment<3>(StateIndex::kVx)).norm(), 1e-3);  // it moved
}

TEST(VehicleModel, NonFiniteStateOrInputIsReportedNotPropagated) {
  const VehicleModel<double> model(testing::make_params(4), Fidelity::kIdeal);
  Vector x = Vector::Zero(model.state_size());
  Vector u = Vector::Zero(model.input_size());
  Vector x_dot(model.state_size());
  x(StateIndex::kVy) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(model.derivative(x, u, x_dot), ModelStatus::kNonFiniteState);
  EXPECT_TRUE(x_dot.array().isNaN().all());
  x(StateIndex::kVy) = 0.0;
  u(3) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(model.derivative(x, u, x_dot), ModelStatus::kNonFiniteInput);
  EXPECT_STREQ(to_string(ModelStatus::kNonFiniteInput), "non_finite_input");
  u(3) = 0.0;
  Vector wrong(3);
  EXPECT_EQ(model.derivative(wrong, u, x_dot), ModelStatus::kInvalidArgument);
  EXPECT_EQ(model.derivative(x, u, x_dot), ModelStatus::kOk);
}

TEST(VehicleModel, VehicleAtRestWithSpinningWheelsPushesExactlyWithTheTireForceAtItsWeight) {
  // At rest, wheels straight, every wheel spinning at w (and steering at rate w): each wheel slips
  // by the same kappa, so the tire forces, linear in the load, sum to F(kappa, m g) along x, with
  // no side force and (loads in moment balance about the CoM) no yaw moment. Standstill (w = 0)
  // gives exactly zero everywhere.
  for (int n : {2, 3, 4, 16}) {
    const VehicleParams params = testing::make_params(n);
    const VehicleModel<double> model(params, Fidelity::kIdeal);
    const MagicFormulaTire<double> tire(params.tire);
    Vector x = Vector::Zero(model.state_size());
    for (double w : {0.0, 1e-9, 1.0, -20.0}) {
      SCOPED_TRACE(std::to_string(n) + " modules, w = " + std::to_string(w));
      const Vector u = Vector::Constant(model.input_size(), w);
      Vector x_dot(model.state_size());
      ASSERT_EQ(model.derivative(x, u, x_dot), ModelStatus::kOk);
      if (w == 0.0) {
        EXPECT_EQ(x_dot, Vector::Zero(model.state_size()));
        continue;
      }
      const auto slip = compute_wheel_slip(params.tire, 0.0, 0.0, w * params.layout.wheel_radius());
      const double expected =
          tire.forces(slip.slip_ratio, slip.slip_angle, params.mass * params.gravity).fx_wheel / params.mass;
      // Tolerance: n products summed in a different order than F(kappa, m g); relative 1e-12 is
      // rounding (plus 1e-15 absolute for the 1e-9 rad/s case, whose force is ~1e-7 N).
      EXPECT_NEAR(x_dot(StateIndex::kVx), expected, 1e-12 * std::abs(expected) + 1e-15);
      EXPECT_NE(x_dot(StateIndex::kVx), 0.0);
      EXPECT_EQ(x_dot(StateIndex::kVy), 0.0);
      // Tolerance: sum of n moments (<= 8 kN x 1 m) cancelling to zero; 1e-12 rad/s^2 is rounding.
      EXPECT_NEAR(x_dot(StateIndex::kYawRate), 0.0, 1e-12);
      EXPECT_EQ(x_dot.head<3>(), Eigen::Vector3d::Zero());  // at rest the pose does not move yet
      for (int i = 0; i < n; ++i) EXPECT_EQ(x_dot(StateIndex::steering(i)), w);
    }
  }
}

TEST(VehicleModel, PlantFidelityAddsLaggedActuatorAndTransientSlipStates) {
  VehicleParams params = testing::make_params(4);
  params.plant.relaxation_length = 0.1;
  params.cog_height = 0.3;
  params.plant.load_transfer = true;
  const VehicleModel<double> ideal(params, Fidelity::kIdeal);
  const VehicleModel<double> plant(params, Fidelity::kPlant);
  EXPECT_EQ(ideal.state_size(), 6 + 4);
  EXPECT_EQ(plant.state_size(), 6 + 4 + 8 + 8);
  EXPECT_EQ(plant.input_size(), 8);
  EXPECT_EQ(plant.wheel_speed_index(0), 10);
  EXPECT_EQ(plant.steering_rate_index(3), 17);
  EXPECT_EQ(plant.transient_slip_ratio_index(1), 20);
  EXPECT_EQ(plant.transient_slip_angle_index(1), 21);
  EXPECT_EQ(ideal.wheel_speed_index(0), -1);

  Vector prefix = Vector::Zero(10);
  prefix(StateIndex::kVx) = 1.0;
  Vector x = plant.complete_state(prefix);
  EXPECT_NEAR(x(plant.wheel_speed_index(2)), 1.0 / params.layout.wheel_radius(), 1e-12);
  Vector u = Vector::Zero(plant.input_size());
  for (int i = 0; i < 4; ++i) u(InputIndex::wheel_speed(i)) = 1.0 / params.layout.wheel_radius();
  u(InputIndex::steering_rate(0)) = 50.0;  // saturated to the 1 rad/s limit
  Vector x_dot(plant.state_size());
  ASSERT_EQ(plant.derivative(x, u, x_dot), ModelStatus::kOk);
  // Rolling steadily: nothing changes but the pose; the steering-rate state lags towards 1 rad/s.
  EXPECT_NEAR(x_dot(StateIndex::kVx), 0.0, 1e-9);
  EXPECT_NEAR(x_dot(plant.wheel_speed_index(0)), 0.0, 1e-9);
  EXPECT_NEAR(x_dot(plant.steering_rate_index(0)), 1.0 / params.actuators.steering_time_constant, 1e-9);
  EXPECT_EQ(x_dot(StateIndex::steering(0)), 0.0);  // the actual rate is still zero
  // Accelerating: wheel-speed command far above -> acceleration clamped to the drive limit.
  u(InputIndex::wheel_speed(1)) = 1e3;
  ASSERT_EQ(plant.derivative(x, u, x_dot), ModelStatus::kOk);
  EXPECT_NEAR(x_dot(plant.wheel_speed_index(1)),
              params.layout.limits().max_drive_acceleration / params.layout.wheel_radius(), 1e-9);
}

TEST(VehicleModel, LoadTransferMovesLoadToTheRearWhenAccelerating) {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(1.0, 0.6, 0.1));
  params.cog_height = 0.4;
  params.plant.load_transfer = true;
  params.plant.actuator_lag = false;
  params.plant.actuator_saturation = false;
  const VehicleModel<double> plant(params, Fidelity::kPlant);
  Vector x = Vector::Zero(plant.state_size());
  Vector u = Vector::Zero(plant.input_size());
  x(StateIndex::kVx) = 1.0;
  for (int i = 0; i < 4; ++i) u(InputIndex::wheel_speed(i)) = 1.02 / params.layout.wheel_radius();
  Vector x_dot(plant.state_size());
  std::vector<ModuleDiagnostics<double>> diag(4);
  ASSERT_EQ(plant.derivative(x, u, x_dot, diag.data()), ModelStatus::kOk);
  double total = 0.0;
  for (const auto& d : diag) total += d.normal_load;
  EXPECT_NEAR(total, params.mass * params.gravity, 1e-6);
  EXPECT_GT(diag[2].normal_load, diag[0].normal_load);  // rear left > front left
  // Quasi-static pitch balance at the first-pass a_x (forces at the static loads): with the four
  // modules at x = +-L/2 the least-norm transfer is dFz = -h m a_x x_i / sum x_j^2, i.e.
  // -+ h m a_x / (2 L) per front / rear wheel. The tire force is linear in the load, so the
  // first-pass a_x = F(kappa, m g) / m whatever the static split.
  const double wheelbase = 1.0;
  const MagicFormulaTire<double> tire(params.tire);
  const auto slip = compute_wheel_slip(params.tire, 1.0, 0.0, 1.02);
  const double a_x =
      tire.forces(slip.slip_ratio, slip.slip_angle, params.mass * params.gravity).fx_wheel / params.mass;
  ASSERT_GT(a_x, 0.5);  // a clear acceleration, so a halved transfer is far outside the tolerance
  const double transfer = params.cog_height.value() * params.mass * a_x / (2.0 * wheelbase);
  const double quarter = params.mass * params.gravity / 4.0;
  // Tolerance: the loads are sums of a few products of O(1e3) N; 1e-9 N is rounding only.
  constexpr double kLoadTolerance = 1e-9;
  EXPECT_NEAR(diag[0].normal_load, quarter - transfer, kLoadTolerance);  // front left
  EXPECT_NEAR(diag[1].normal_load, quarter - transfer, kLoadTolerance);  // front right
  EXPECT_NEAR(diag[2].normal_load, quarter + transfer, kLoadTolerance);  // rear left
  EXPECT_NEAR(diag[3].normal_load, quarter + transfer, kLoadTolerance);  // rear right
}

// 4 modules with transient slip (relaxation 0.1 m) and neither actuator lag nor saturation, so the
// tread speed is the command.
VehicleParams transient_slip_params() {
  VehicleParams params = testing::make_params(4);
  params.plant.relaxation_length = 0.1;
  params.plant.actuator_lag = false;
  params.plant.actuator_saturation = false;
  return params;
}

// Every wheel commanded to a tread speed of `tread` m/s, steering still.
Vector tread_commands(const VehicleModel<double>& plant, const VehicleParams& params, double tread) {
  Vector u = Vector::Zero(plant.input_size());
  for (int i = 0; i < params.layout.size(); ++i) u(InputIndex::wheel_speed(i)) = tread / params.layout.wheel_radius();
  return u;
}

TEST(VehicleModel, TransientSlipRelaxesTowardsTheSteadySlipAtRateSpeedOverRelaxationLength) {
  // Pacejka 2012, sec. 7.2.2: sigma kappa'_dot = V (kappa - kappa'), V = sqrt(u^2 + V_r^2 + eps^2).
  // Rolling straight at 1 m/s with the wheels commanded 2 % faster (no actuator lag, so V_r is the
  // command) and the transient slips still 0: each transient slip ratio rises at V kappa / sigma,
  // the slip angle stays, and no force acts yet (the forces follow the transient slips).
  VehicleParams params = transient_slip_params();
  const VehicleModel<double> plant(params, Fidelity::kPlant);
  Vector x = Vector::Zero(plant.state_size());
  x(StateIndex::kVx) = 1.0;
  const double tread = 1.02;
  const Vector u = tread_commands(plant, params, tread);
  Vector x_dot(plant.state_size());
  ASSERT_EQ(plant.derivative(x, u, x_dot), ModelStatus::kOk);
  const auto slip = compute_wheel_slip(params.tire, 1.0, 0.0, tread);
  const double eps = params.tire.slip_speed_epsilon;
  const double rate = std::sqrt(1.0 + tread * tread + eps * eps) / params.plant.relaxation_length;
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    // Tolerance: the same few operations in a different order; 1e-12 relative is rounding.
    EXPECT_NEAR(x_dot(plant.transient_slip_ratio_index(i)), rate * slip.slip_ratio,
                1e-12 * rate * slip.slip_ratio);
    EXPECT_GT(x_dot(plant.transient_slip_ratio_index(i)), 0.0);
    EXPECT_EQ(x_dot(plant.transient_slip_angle_index(i)), 0.0);
  }
  EXPECT_EQ(x_dot(StateIndex::kVx), 0.0);
}

// With a relaxation length the contact slides at what the transient slips stand for (kappa' times
// the slip ratio's normalising speed), and the frictional power is the transient force times that:
// the rest of the wheel-ground speed difference deflects the carcass. By hand: rolling at 1 m/s with
// the tread 2 % faster, kappa = 0.02 / max(1, 1.02, eps) (non-smooth slip) and kappa' set to a
// third of it, then to a negative value (the deflection giving energy back while the wheel still
// runs ahead). F times the kinematic slip velocity would be 3x too much in the first case and
// would count the second as wear at all.
TEST(VehicleModel, WithTransientSlipTheWearIsTheTransientForceTimesTheSlidingItStandsFor) {
  VehicleParams params = transient_slip_params();
  params.tire.smooth_slip = false;
  const VehicleModel<double> plant(params, Fidelity::kPlant);
  Vector x = Vector::Zero(plant.state_size());
  x(StateIndex::kVx) = 1.0;
  const double tread = 1.02;
  const Vector u = tread_commands(plant, params, tread);
  const double kappa = 0.02 / tread;
  const MagicFormulaTire<double> tire(params.tire);
  const double fz = params.mass * params.gravity / 4.0;
  for (const double transient : {kappa / 3.0, -0.005}) {
    SCOPED_TRACE(transient);
    for (int i = 0; i < 4; ++i) x(plant.transient_slip_ratio_index(i)) = transient;
    Vector x_dot(plant.state_size());
    std::vector<ModuleDiagnostics<double>> diag(4);
    ASSERT_EQ(plant.derivative(x, u, x_dot, diag.data()), ModelStatus::kOk);
    const double force = tire.forces(transient, 0.0, fz).fx_wheel;
    const double sliding = transient * tread;  // kappa' times max(|u|, |V_r|) = 1.02 m/s
    for (int i = 0; i < 4; ++i) {
      // Tolerance: a product of a few terms of O(1e3) N and O(1e-2) m/s; 1e-9 W is rounding.
      EXPECT_NEAR(diag[static_cast<std::size_t>(i)].fx_wheel, force, 1e-9);
      EXPECT_NEAR(diag[static_cast<std::size_t>(i)].slip_velocity_x_wheel, sliding, 1e-15);
      EXPECT_NEAR(diag[static_cast<std::size_t>(i)].frictional_power, force * sliding, 1e-9);
      EXPECT_GE(diag[static_cast<std::size_t>(i)].frictional_power, 0.0);
    }
  }
}

TEST(VehicleModel, ADeadDrivesTireGivesNoLongitudinalForceAndOnlyItsPureLateralOne) {
  // Independent truth: the tire alone at no slip ratio and the module's slip angle.
  const VehicleParams params = testing::make_params(4);
  VehicleModel<double> model(params, Fidelity::kIdeal);
  ModuleFaults faults(4, ModuleFault::kNone);
  faults[1] = ModuleFault::kDeadDrive;
  model.observe_module_faults(&faults);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(10), u = Eigen::VectorXd::Zero(8), x_dot(10);
  x[StateIndex::kVx] = 1.0;
  x[StateIndex::kVy] = 0.04;
  for (int i = 0; i < 4; ++i) u[InputIndex::wheel_speed(i)] = 1.3 / params.layout.wheel_radius();  // driving hard
  std::vector<ModuleDiagnostics<double>> d(4);
  ASSERT_EQ(model.derivative(x, u, x_dot, d.data()), ModelStatus::kOk);
  EXPECT_EQ(d[1].fx_wheel, 0.0);
  EXPECT_EQ(d[1].slip_ratio, 0.0);
  const MagicFormulaTire<double> tire(params.tire);
  EXPECT_NEAR(d[1].fy_wheel, tire.forces(0.0, d[1].slip_angle, d[1].normal_load).fy_wheel, 1e-12);
  EXPECT_NEAR(d[1].wear_rate, std::abs(d[1].fy_wheel * d[1].slip_velocity_y_wheel), 1e-12);
  EXPECT_GT(d[0].fx_wheel, 1.0);  // the healthy drives still drive
}

TEST(VehicleModel, AFrictionScaleGivesAModuleTheForcesOfATireWithThatMuAndLeavesItsLoad) {
  // Independent truth: the same vehicle with the tire's mu halved. Module 2 alone stands on the
  // half grip; every other module keeps the tire's forces.
  const VehicleParams params = testing::make_params(4);
  VehicleParams slippery = params;
  slippery.tire.mu = 0.5 * params.tire.mu;
  VehicleModel<double> model(params, Fidelity::kIdeal);
  const VehicleModel<double> dry(params, Fidelity::kIdeal), wet(slippery, Fidelity::kIdeal);
  const double scales[4] = {1.0, 1.0, 0.5, 1.0};
  model.observe_friction_scales(scales);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(10), u = Eigen::VectorXd::Zero(8), x_dot(10);
  x[StateIndex::kVx] = 1.0;
  x[StateIndex::kVy] = 0.03;
  x[StateIndex::kYawRate] = 0.2;
  for (int i = 0; i < 4; ++i) u[InputIndex::wheel_speed(i)] = 1.1 / params.layout.wheel_radius();
  std::vector<ModuleDiagnostics<double>> scaled(4), dry_diagnostics(4), wet_diagnostics(4);
  ASSERT_EQ(model.derivative(x, u, x_dot, scaled.data()), ModelStatus::kOk);
  ASSERT_EQ(dry.derivative(x, u, x_dot, dry_diagnostics.data()), ModelStatus::kOk);
  ASSERT_EQ(wet.derivative(x, u, x_dot, wet_diagnostics.data()), ModelStatus::kOk);
  for (int i = 0; i < 4; ++i) {
    const ModuleDiagnostics<double>& truth = i == 2 ? wet_diagnostics[static_cast<std::size_t>(i)]
                                                    : dry_diagnostics[static_cast<std::size_t>(i)];
    const ModuleDiagnostics<double>& d = scaled[static_cast<std::size_t>(i)];
    EXPECT_NEAR(d.fx_wheel, truth.fx_wheel, 1e-9 * std::abs(truth.fx_wheel) + 1e-12) << "module " << i;
    EXPECT_NEAR(d.fy_wheel, truth.fy_wheel, 1e-9 * std::abs(truth.fy_wheel) + 1e-12) << "module " << i;
    EXPECT_NEAR(d.wear_rate, truth.wear_rate, 1e-9 * truth.wear_rate + 1e-15) << "module " << i;
    EXPECT_DOUBLE_EQ(d.normal_load, dry_diagnostics[static_cast<std::size_t>(i)].normal_load) << "module " << i;
  }
  EXPECT_NE(scaled[2].fy_wheel, dry_diagnostics[2].fy_wheel);  // the case is not vacuous
}

}  // namespace
}  // namespace swerve
