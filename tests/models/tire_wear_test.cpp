// Tire wear against hand-derived truth: zero without slip (pure rolling, and a kinematically
// consistent turn at vanishing speed), non-negative everywhere, quadratic in slip angle with the
// constant B C D u derived by hand, growing with load; the Archard variant and validation.
#include "swerve/models/tire_wear.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "support/model_fixtures.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {
namespace {

// Wear rate of one wheel moving at (u, v) with tread speed vr (wheel frame) under load fz.
double wheel_wear(const MagicFormulaParams& tire_params, const WearParams& wear, double u, double v, double vr,
                  double fz, double* power = nullptr) {
  const MagicFormulaTire<double> tire(tire_params);
  const auto slip = compute_wheel_slip(tire_params, u, v, vr);
  const auto f = tire.forces(slip.slip_ratio, slip.slip_angle, fz);
  if (power != nullptr) *power = frictional_power(f, slip);
  return wear_rate(wear, f, slip, fz);
}

TEST(TireWear, IsZeroForPureRolling) {
  for (double speed : {0.0, 1e-6, 0.3, 2.0, -1.0}) {
    double power = -1.0;
    EXPECT_EQ(wheel_wear(MagicFormulaParams{}, WearParams{}, speed, 0.0, speed, 1000.0, &power), 0.0);
    EXPECT_EQ(power, 0.0);
    WearParams archard;
    archard.model = WearModelKind::kArchard;
    EXPECT_NEAR(wheel_wear(MagicFormulaParams{}, archard, speed, 0.0, speed, 1000.0), 0.0, 1e-12);
  }
}

TEST(TireWear, IsZeroOnAKinematicallyConsistentTurnAtVanishingSpeed) {
  // Every wheel aligned with its contact velocity and rolling at its speed: no slip anywhere.
  for (const auto& named : testing::test_layouts()) {
    const VehicleModel<double> model(testing::make_params(named.layout), Fidelity::kIdeal);
    for (double scale : {1e-6, 1e-3, 1.0}) {
      const double vx = 0.8 * scale;
      const double vy = 0.3 * scale;
      const double r = 0.5 * scale;
      Eigen::VectorXd x = Eigen::VectorXd::Zero(model.state_size());
      Eigen::VectorXd u = Eigen::VectorXd::Zero(model.input_size());
      x(StateIndex::kVx) = vx;
      x(StateIndex::kVy) = vy;
      x(StateIndex::kYawRate) = r;
      for (int i = 0; i < model.modules(); ++i) {
        const Eigen::Vector2d& p = named.layout.position_body(i);
        const double cvx = vx - r * p.y();
        const double cvy = vy + r * p.x();
        x(StateIndex::steering(i)) = std::atan2(cvy, cvx);
        u(InputIndex::wheel_speed(i)) = std::hypot(cvx, cvy) / named.layout.wheel_radius();
      }
      Eigen::VectorXd x_dot(model.state_size());
      double wear = -1.0;
      ASSERT_EQ(model.derivative(x, u, x_dot, nullptr, &wear), ModelStatus::kOk);
      EXPECT_NEAR(wear, 0.0, 1e-9 * scale) << named.name << " scale " << scale;
    }
  }
}

TEST(TireWear, IsNonNegativeEverywhere) {
  for (auto model : {WearModelKind::kFrictionalPower, WearModelKind::kArchard}) {
    for (auto method : {CombinedSlipMethod::kNone, CombinedSlipMethod::kEllipseCap, CombinedSlipMethod::kNormalizedSlip}) {
      MagicFormulaParams tire;
      tire.combined_slip = method;
      WearParams wear;
      wear.model = model;
      for (double u = -1.0; u <= 1.0; u += 0.125) {
        for (double v = -1.0; v <= 1.0; v += 0.125) {
          for (double vr = -1.0; vr <= 1.0; vr += 0.125) {
            ASSERT_GE(wheel_wear(tire, wear, u, v, vr, 800.0), 0.0) << u << " " << v << " " << vr;
          }
        }
      }
    }
  }
}

TEST(TireWear, IsQuadraticInSlipAngleWithTheHandDerivedConstant) {
  // Pure side slip at speed u with V_r = u: Fy = D sin(C atan(B alpha)) ~ B C D alpha and the
  // lateral sliding speed |v| = u tan(alpha) ~ u alpha, so w_dot = k |Fy v| ~ k B C D u alpha^2.
  MagicFormulaParams tire;
  tire.slip_speed_epsilon = 1e-9;  // so that alpha is exactly -atan(v/u) here
  WearParams wear;
  wear.coefficient = 2.0;
  const double u = 1.5;
  const double fz = 1000.0;
  const double constant = wear.coefficient * tire.lateral.b * tire.lateral.c * tire.mu * fz * u;
  for (double alpha : {1e-4, 5e-4, 1e-3}) {
    const double w = wheel_wear(tire, wear, u, -u * std::tan(alpha), u, fz);
    EXPECT_NEAR(w / (alpha * alpha), constant, 2e-3 * constant) << "alpha " << alpha;
  }
  const double w1 = wheel_wear(tire, wear, u, -u * std::tan(1e-3), u, fz);
  const double w2 = wheel_wear(tire, wear, u, -u * std::tan(2e-3), u, fz);
  EXPECT_NEAR(w2 / w1, 4.0, 4.0 * 2e-3);
}

TEST(TireWear, GrowsWithLoad) {
  double previous = 0.0;
  for (double fz : {100.0, 500.0, 1000.0, 3000.0}) {
    const double w = wheel_wear(MagicFormulaParams{}, WearParams{}, 1.0, 0.05, 1.1, fz);
    EXPECT_GT(w, previous) << fz;
    previous = w;
  }
  WearParams archard;
  archard.model = WearModelKind::kArchard;
  EXPECT_GT(wheel_wear(MagicFormulaParams{}, archard, 1.0, 0.05, 1.1, 2000.0),
            wheel_wear(MagicFormulaParams{}, archard, 1.0, 0.05, 1.1, 1000.0));
}

TEST(TireWear, ArchardIsLoadTimesSlidingSpeed) {
  WearParams archard;
  archard.model = WearModelKind::kArchard;
  archard.coefficient = 3.0;
  // Sliding velocity (V_r - u, -v) = (0.3, -0.4): |v_slip| = 0.5.
  const double w = wheel_wear(MagicFormulaParams{}, archard, 1.0, 0.4, 1.3, 700.0);
  EXPECT_NEAR(w, 3.0 * 700.0 * 0.5, 1e-6);
}

TEST(TireWear, FrictionalPowerIsForceTimesSlidingSpeed) {
  TireForces<double> f{100.0, -50.0};
  WheelSlip<double> slip;
  slip.slip_velocity_x_wheel = 0.2;
  slip.slip_velocity_y_wheel = -0.1;
  EXPECT_DOUBLE_EQ(frictional_power(f, slip), 100.0 * 0.2 + 50.0 * 0.1);
  // The smoothed |.| is within the smoothing of the exact value and zero at zero.
  EXPECT_NEAR(frictional_power(f, slip, 0.01), 25.0, 0.02);
  EXPECT_EQ(frictional_power(TireForces<double>{}, WheelSlip<double>{}, 0.01), 0.0);
}

TEST(WearParams, RejectsEachBadFieldNamingItAndItsValue) {
  WearParams p;
  p.coefficient = -1.0;
  try {
    p.validate();
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("WearParams.coefficient = -1"), std::string::npos) << e.what();
  }
  p = {};
  p.smoothing = std::nan("");
  try {
    p.validate();
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("WearParams.smoothing = nan"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace swerve
