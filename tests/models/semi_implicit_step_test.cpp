// The prediction's discrete step (SemiImplicitStep) on its own: hand-derived motions (rolling
// straight, a steady arc as the SE(2) exponential, the linear-damper limit of a speed step), its
// Jet evaluation against its double evaluation and central differences, caller-owned scratch, the
// smoothing primitives' seams, and bad options.
#include "swerve/models/semi_implicit_step.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "support/model_fixtures.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/models/jet.hpp"

namespace swerve {
namespace {

constexpr double kDt = 0.05;

// The 4-module test vehicle (160 kg) with ideal drives, so the step charges a command change its
// whole energy balance (no lag share).
VehicleParams ideal_vehicle() {
  VehicleParams params = testing::make_params(4);
  params.plant.actuator_lag = false;
  return params;
}

// State (pose, twist, steering) with every module steered along its contact velocity under
// `twist_body`, and the inputs that keep them there: the rolling motion of that twist.
struct Rolling {
  Eigen::VectorXd x, u;
};
Rolling rolling(const VehicleParams& params, const Eigen::Vector3d& twist_body) {
  const int n = params.layout.size();
  Rolling r{Eigen::VectorXd::Zero(StateIndex::prefix_size(n)), Eigen::VectorXd::Zero(2 * n)};
  r.x.segment<3>(StateIndex::kVx) = twist_body;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = params.layout.position_body(i);
    const double vx = twist_body.x() - twist_body.z() * p.y();
    const double vy = twist_body.y() + twist_body.z() * p.x();
    r.x[StateIndex::steering(i)] = std::atan2(vy, vx);
    r.u[InputIndex::wheel_speed(i)] = std::hypot(vx, vy) / params.layout.wheel_radius();
  }
  return r;
}

TEST(SemiImplicitStep, RollingStraightKeepsTheTwistMovesTheExactDistanceAndWearsAlmostNothing) {
  const VehicleParams params = ideal_vehicle();
  const SemiImplicitStep<double> step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data data(step);
  const Rolling r = rolling(params, {1.0, 0.0, 0.0});
  Eigen::VectorXd x_next(r.x.size());
  double wear = -1.0;
  ASSERT_TRUE(step.step(data, r.x, r.u, kDt, x_next, &wear));
  EXPECT_NEAR(x_next[StateIndex::kX], 0.05, 1e-6);
  EXPECT_NEAR(x_next[StateIndex::kY], 0.0, 1e-9);
  EXPECT_NEAR(x_next[StateIndex::kVx], 1.0, 1e-6);
  EXPECT_GE(wear, 0.0);
  EXPECT_LT(wear, 1e-3);  // J: steady rolling dissipates nothing but the blend's 5e-5 J bias
}

TEST(SemiImplicitStep, OnASteadyArcThePoseFollowsTheSe2ExponentialOfTheStepsTwist) {
  // The body moves with its end-of-step twist (vx, vy, r) over dt: from the origin,
  // x = (vx sin(r dt) - vy (1 - cos(r dt))) / r, y = (vx (1 - cos(r dt)) + vy sin(r dt)) / r,
  // psi = r dt. The tyres need a slip angle for the centripetal force (m v r = 80 N against ~25 kN
  // per rad of cornering stiffness), so vy settles a few mm/s off the kinematic 0.
  const VehicleParams params = ideal_vehicle();
  const SemiImplicitStep<double> step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data data(step);
  const Rolling r = rolling(params, {1.0, 0.0, 0.5});
  Eigen::VectorXd x_next(r.x.size());
  double wear = 0.0;
  ASSERT_TRUE(step.step(data, r.x, r.u, kDt, x_next, &wear));
  const double vx = x_next[StateIndex::kVx], vy = x_next[StateIndex::kVy], yaw_rate = x_next[StateIndex::kYawRate];
  EXPECT_NEAR(vx, 1.0, 1e-3);
  EXPECT_NEAR(vy, 0.0, 1e-2);
  EXPECT_NEAR(yaw_rate, 0.5, 1e-3);
  const double turn = yaw_rate * kDt;
  EXPECT_NEAR(x_next[StateIndex::kX], (vx * std::sin(turn) - vy * (1.0 - std::cos(turn))) / yaw_rate, 1e-12);
  EXPECT_NEAR(x_next[StateIndex::kY], (vx * (1.0 - std::cos(turn)) + vy * std::sin(turn)) / yaw_rate, 1e-12);
  EXPECT_NEAR(x_next[StateIndex::kPsi], turn, 1e-12);
  for (int i = 0; i < params.layout.size(); ++i) {
    EXPECT_NEAR(x_next[StateIndex::steering(i)], r.x[StateIndex::steering(i)], 1e-12) << "module " << i;
  }
}

TEST(SemiImplicitStep, ASuddenSpeedStepWearsItsEnergyBalanceNearTheLinearDamperLimit) {
  // Wheels commanded 10 % faster than the body rolls, straight ahead. Backward Euler makes the
  // tyres' impulse h sum(Fx) equal m (v+ - v0), so the drives' work is m (v+ - v0) v_wheel and the
  // stage wear (coefficient 1) is m (v+ - v0) v_wheel - m (v+^2 - v0^2) / 2 (less the 5e-5 J
  // bias of the positive-part blend); the tyres pull the body
  // most of the way within the step, so that is close to the damper limit 1/2 m dv^2 = 0.8 J.
  const VehicleParams params = ideal_vehicle();
  const SemiImplicitStep<double> step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data data(step);
  const Rolling r = rolling(params, {1.0, 0.0, 0.0});
  Eigen::VectorXd x_next(r.x.size());
  double wear = 0.0;
  ASSERT_TRUE(step.step(data, r.x, r.u * 1.1, kDt, x_next, &wear));
  const double v0 = 1.0, v_wheel = 1.1, v = x_next[StateIndex::kVx], m = params.mass;
  EXPECT_GT(v, 1.05);
  EXPECT_LT(v, 1.1);
  constexpr double kBlendBias = 5e-5;  // J: positive_part above its blend is x - width / 2
  EXPECT_NEAR(wear, m * (v - v0) * v_wheel - 0.5 * m * (v * v - v0 * v0) - kBlendBias, 1e-9);
  EXPECT_NEAR(wear, 0.5 * m * 0.1 * 0.1, 0.05 * 0.8);
}

TEST(SemiImplicitStep, ItsJetEvaluationHasTheDoubleValueAndTheCentralDifferenceAsDerivative) {
  const VehicleParams params = ideal_vehicle();
  const SemiImplicitStep<double> step(params, PredictionOptions{});
  const SemiImplicitStep<ModelJet> jet_step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data data(step);
  SemiImplicitStep<ModelJet>::Data jet_data(jet_step);
  // A turning body whose modules are a little off their rolling angles and speeds.
  Rolling r = rolling(params, {0.8, 0.1, 0.3});
  for (int i = 0; i < params.layout.size(); ++i) {
    r.x[StateIndex::steering(i)] += 0.02 * (i + 1);
    r.u[InputIndex::steering_rate(i)] = 0.1 * (i % 2 == 0 ? 1.0 : -1.0);
    r.u[InputIndex::wheel_speed(i)] *= 1.0 + 0.01 * i;
  }
  const int nx = static_cast<int>(r.x.size());
  // Seed direction 0 on module 1's wheel speed and direction 1 on the lateral velocity.
  const int seeded_input = InputIndex::wheel_speed(1);
  Eigen::Matrix<ModelJet, Eigen::Dynamic, 1> x_jet(nx), u_jet(r.u.size()), next_jet(nx);
  for (int k = 0; k < nx; ++k) x_jet[k] = ModelJet(r.x[k]);
  for (Eigen::Index k = 0; k < r.u.size(); ++k) u_jet[k] = ModelJet(r.u[k]);
  u_jet[seeded_input].v[0] = 1.0;
  x_jet[StateIndex::kVy].v[1] = 1.0;
  SemiImplicitStep<ModelJet>::begin_chunk(jet_data, true);
  ModelJet wear_jet(0.0);
  ASSERT_TRUE(jet_step.step(jet_data, x_jet, u_jet, kDt, next_jet, &wear_jet));

  Eigen::VectorXd next(nx), plus(nx), minus(nx);
  double wear = 0.0, wear_plus = 0.0, wear_minus = 0.0;
  ASSERT_TRUE(step.step(data, r.x, r.u, kDt, next, &wear));
  for (int k = 0; k < nx; ++k) EXPECT_NEAR(next_jet[k].a, next[k], 1e-10) << "state " << k;
  EXPECT_NEAR(wear_jet.a, wear, 1e-10);

  constexpr double kH = 1e-6;
  auto check = [&](int direction, const char* what) {
    for (int k = 0; k < nx; ++k) {
      const double fd = (plus[k] - minus[k]) / (2.0 * kH);
      EXPECT_NEAR(next_jet[k].v[direction], fd, 1e-5 + 1e-4 * std::abs(fd)) << what << ", state " << k;
    }
    const double fd_wear = (wear_plus - wear_minus) / (2.0 * kH);
    EXPECT_NEAR(wear_jet.v[direction], fd_wear, 1e-5 + 1e-3 * std::abs(fd_wear)) << what << ", wear";
  };
  Eigen::VectorXd u_shift = r.u;
  u_shift[seeded_input] += kH;
  ASSERT_TRUE(step.step(data, r.x, u_shift, kDt, plus, &wear_plus));
  u_shift[seeded_input] -= 2.0 * kH;
  ASSERT_TRUE(step.step(data, r.x, u_shift, kDt, minus, &wear_minus));
  check(0, "d/d wheel speed 1");
  Eigen::VectorXd x_shift = r.x;
  x_shift[StateIndex::kVy] += kH;
  ASSERT_TRUE(step.step(data, x_shift, r.u, kDt, plus, &wear_plus));
  x_shift[StateIndex::kVy] -= 2.0 * kH;
  ASSERT_TRUE(step.step(data, x_shift, r.u, kDt, minus, &wear_minus));
  check(1, "d/d vy");
}

TEST(SemiImplicitStep, StepsThroughTwoScratchObjectsAreBitIdentical) {
  // The step is immutable; each Data holds one caller's scratch (and Newton warm starts nothing
  // across calls), so interleaving two Data gives what each gives alone.
  const VehicleParams params = ideal_vehicle();
  const SemiImplicitStep<double> step(params, PredictionOptions{});
  SemiImplicitStep<double>::Data first(step), second(step);
  const Rolling a = rolling(params, {1.0, 0.0, 0.2});
  const Rolling b = rolling(params, {0.1, 0.05, 0.0});  // slow: the substepped branch
  Eigen::VectorXd alone(a.x.size()), interleaved(a.x.size()), other(b.x.size());
  double wear_alone = 0.0, wear_interleaved = 0.0, wear_other = 0.0;
  ASSERT_TRUE(step.step(first, a.x, a.u * 1.05, kDt, alone, &wear_alone));
  ASSERT_TRUE(step.step(second, b.x, b.u * 0.9, kDt, other, &wear_other));
  ASSERT_TRUE(step.step(first, a.x, a.u * 1.05, kDt, interleaved, &wear_interleaved));
  EXPECT_EQ(alone, interleaved);
  EXPECT_EQ(wear_alone, wear_interleaved);
}

TEST(SemiImplicitStep, ThePositivePartOfTheEnergyBalanceIsExactOutsideItsBlendAndC1AtItsSeams) {
  using Jet = ceres::Jet<double, 1>;
  EXPECT_EQ(positive_part(-1.0), 0.0);
  constexpr double kWidth = 1e-4;  // positive_part's blend
  for (const double seam : {0.0, kWidth}) {
    const Jet below = positive_part(Jet(seam - 1e-12, 0));
    const Jet above = positive_part(Jet(seam + 1e-12, 0));
    EXPECT_NEAR(below.a, above.a, 1e-10) << "value at " << seam;
    EXPECT_NEAR(below.v[0], above.v[0], 1e-6) << "slope at " << seam;
  }
  EXPECT_NEAR(positive_part(1.0), 1.0 - 0.5 * kWidth, 1e-15);
}

TEST(SemiImplicitStep, RejectsOptionsOutOfRangeNamingTheField) {
  const auto message_of = [](PredictionOptions options) {
    try {
      options.validate();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  PredictionOptions options;
  options.substeps = 0;
  EXPECT_EQ(message_of(options), "PredictionOptions.substeps = 0: must be in [1, 1000]");
  options = PredictionOptions{};
  options.slow_substeps = -2;
  EXPECT_EQ(message_of(options), "PredictionOptions.slow_substeps = -2: must be in [1, 1000]");
  options = PredictionOptions{};
  options.max_newton_iterations = 0;
  EXPECT_EQ(message_of(options), "PredictionOptions.max_newton_iterations = 0: must be in [1, 100]");
  EXPECT_EQ(message_of(PredictionOptions{}), "(accepted)");
}

}  // namespace
}  // namespace swerve
