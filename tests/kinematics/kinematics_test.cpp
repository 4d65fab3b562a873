// Kinematics: hand-derived inverse kinematics per layout family, least-squares forward kinematics
// against an independent dense solve, round trips for 2..8 modules, module optimisation
// (flip, hysteresis, cosine scaling), desaturation, singularity hold, second order against finite
// differences, and bad input.
#include "swerve/app/kinematics_config.hpp"
#include "swerve/kinematics/kinematics.hpp"

#include <gtest/gtest.h>

#include <optional>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <vector>

#include "kinematics/test_layouts.hpp"
#include "swerve/kinematics/se2.hpp"

namespace swerve {
namespace {

using testing::layouts_2_to_8;
using testing::random_layout;
using testing::random_twist;

void expect_state(const ModuleState& state, double speed, double angle, const char* what) {
  EXPECT_NEAR(state.speed, speed, 1e-12) << what;
  EXPECT_NEAR(wrap_angle(state.angle - angle), 0.0, 1e-12) << what << " angle " << state.angle;
}

// Velocity of module i, from a module state.
Eigen::Vector2d velocity_of(const ModuleState& s) { return s.speed * Eigen::Vector2d(std::cos(s.angle), std::sin(s.angle)); }

// ---- inverse kinematics, hand-derived --------------------------------------------------------------

TEST(InverseKinematics, StraightAndStrafePointEveryWheelTheSameWay) {
  for (const auto& [name, layout] : layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    ModuleStates states;
    ASSERT_EQ(kinematics.inverse({1.5, 0.0, 0.0}, &states), KinematicsStatus::kOk);
    ASSERT_EQ(states.size(), layout.size());
    for (const ModuleState& s : states) expect_state(s, 1.5, 0.0, "straight");
    ASSERT_EQ(kinematics.inverse({0.0, -0.7, 0.0}, &states), KinematicsStatus::kOk);
    for (const ModuleState& s : states) expect_state(s, 0.7, -kPi / 2.0, "strafe right");
  }
}

TEST(InverseKinematics, SpinInPlaceMakesWheelsTangent) {
  for (const auto& [name, layout] : layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    ModuleStates states;
    ASSERT_EQ(kinematics.inverse({0.0, 0.0, 2.0}, &states), KinematicsStatus::kOk);
    for (int i = 0; i < layout.size(); ++i) {
      const Eigen::Vector2d r = layout.position_body(i);
      const Eigen::Vector2d direction(std::cos(states[i].angle), std::sin(states[i].angle));
      EXPECT_NEAR(states[i].speed, 2.0 * r.norm(), 1e-12);
      EXPECT_NEAR(direction.dot(r), 0.0, 1e-12);                                 // tangent
      EXPECT_GT(r.x() * direction.y() - r.y() * direction.x(), 0.0);            // counter-clockwise
    }
  }
}

TEST(InverseKinematics, RectangleSpinAboutFrontLeftModuleStopsThatModule) {
  // Rectangle 0.6 x 0.4: FL (0.3, 0.2), FR (0.3, -0.2), RL (-0.3, 0.2), RR (-0.3, -0.2); omega 2
  // about FL: u_i = omega * (-(y_i - 0.2), x_i - 0.3).
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.0, 0.0, 2.0}, &states, {0.3, 0.2}), KinematicsStatus::kOk);
  EXPECT_NEAR(states[0].speed, 0.0, 1e-15);
  expect_state(states[1], 0.8, 0.0, "FR: (0.8, 0)");
  expect_state(states[2], 1.2, -kPi / 2.0, "RL: (0, -1.2)");
  expect_state(states[3], std::hypot(0.8, 1.2), std::atan2(-1.2, 0.8), "RR: (0.8, -1.2)");
}

TEST(InverseKinematics, OffCentreRotationWithTranslationMovesTheCentreAtTheCommandedVelocity) {
  // Centre c = (1, 0) moving at (0.5, 0) with omega = 1: FL u = (0.5 - 0.2, 0.3 - 1) = (0.3, -0.7).
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.5, 0.0, 1.0}, &states, {1.0, 0.0}), KinematicsStatus::kOk);
  expect_state(states[0], std::hypot(0.3, 0.7), std::atan2(-0.7, 0.3), "FL");
  expect_state(states[3], std::hypot(0.7, 1.3), std::atan2(-1.3, 0.7), "RR: (0.5+0.2, -0.3-1)");
  // Forward kinematics reports the reference point, not the centre: (0.5 + 1*0, 0 - 1*1, 1).
  Eigen::Vector3d twist;
  ASSERT_EQ(kinematics.forward(states, &twist), KinematicsStatus::kOk);
  EXPECT_NEAR((twist - Eigen::Vector3d(0.5, -1.0, 1.0)).norm(), 0.0, 1e-12);
}

TEST(InverseKinematics, TriangleSpinPointsWheelsNinetyDegreesAheadOfTheirPosition) {
  const Kinematics kinematics(ModuleLayout::triangle(0.4, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.0, 0.0, -1.0}, &states), KinematicsStatus::kOk);
  // Clockwise: each wheel points 90 deg behind its bearing (0, 120, 240 deg).
  expect_state(states[0], 0.4, -kPi / 2.0, "module 0");
  expect_state(states[1], 0.4, 2.0 * kPi / 3.0 - kPi / 2.0, "module 1");
  expect_state(states[2], 0.4, 4.0 * kPi / 3.0 - kPi / 2.0, "module 2");
}

TEST(InverseKinematics, TwoModuleSpinAboutTheirMidpointDrivesThemOppositeWays) {
  const Kinematics kinematics(ModuleLayout::two_module(0.3, 0.5, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.0, 0.0, 1.0}, &states, {0.3, 0.0}), KinematicsStatus::kOk);
  expect_state(states[0], 0.25, kPi, "left module drives backwards");
  expect_state(states[1], 0.25, 0.0, "right module drives forwards");
}

TEST(InverseKinematics, MultiAxleSpinAboutMiddleLeftModuleStopsOnlyThatModule) {
  const Kinematics kinematics(ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.0, 0.0, 1.0}, &states, {0.0, 0.3}), KinematicsStatus::kOk);
  EXPECT_NEAR(states[2].speed, 0.0, 1e-15);
  expect_state(states[3], 0.6, 0.0, "middle right: (0.6, 0)");
  expect_state(states[0], 0.5, kPi / 2.0, "front left: (0, 0.5)");
}

TEST(InverseKinematics, FieldRelativeInputIsRotatedByTheMeasuredHeading) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  // Heading 30 deg, field +x: the body sees it 30 deg to its right.
  ASSERT_EQ(kinematics.inverse(twist_world_to_body({1.0, 0.0, 0.0}, kPi / 6.0), &states),
            KinematicsStatus::kOk);
  for (const ModuleState& s : states) expect_state(s, 1.0, -kPi / 6.0, "field forward");
}

// ---- forward kinematics ----------------------------------------------------------------------------

// Independent least squares: dense weighted system solved by QR.
Eigen::Vector3d dense_least_squares(const ModuleLayout& layout, const ModuleStates& states,
                                    const Eigen::VectorXd& weights) {
  const int n = layout.size();
  Eigen::MatrixXd a(2 * n, 3);
  Eigen::VectorXd b(2 * n);
  for (int i = 0; i < n; ++i) {
    const double w = std::sqrt(weights(i));
    const Eigen::Vector2d r = layout.position_body(i);
    a.row(2 * i) << w, 0.0, -w * r.y();
    a.row(2 * i + 1) << 0.0, w, w * r.x();
    b.segment<2>(2 * i) = w * velocity_of(states[i]);
  }
  return a.colPivHouseholderQr().solve(b);
}

TEST(ForwardKinematics, RoundTripsInverseKinematicsForTwoToEightModules) {
  std::mt19937 rng(11);
  for (int count = 2; count <= 8; ++count) {
    for (int trial = 0; trial < 20; ++trial) {
      const ModuleLayout layout = random_layout(count, rng);
      const Kinematics kinematics(layout);
      const Eigen::Vector3d twist = random_twist(rng);
      const Eigen::Vector2d centre = random_twist(rng).head<2>();
      ModuleStates states;
      ASSERT_EQ(kinematics.inverse(twist, &states, centre), KinematicsStatus::kOk);
      Eigen::Vector3d recovered;
      ASSERT_EQ(kinematics.forward(states, &recovered), KinematicsStatus::kOk);
      // The reference point moves with v_c + omega x (0 - c).
      const Eigen::Vector3d expected(twist.x() + twist.z() * centre.y(), twist.y() - twist.z() * centre.x(), twist.z());
      EXPECT_NEAR((recovered - expected).norm(), 0.0, 1e-10) << count << " modules";
      // And back: the module states of the recovered twist are the ones we started from.
      ModuleStates again;
      ASSERT_EQ(kinematics.inverse(recovered, &again), KinematicsStatus::kOk);
      for (int i = 0; i < count; ++i) {
        EXPECT_NEAR((velocity_of(again[i]) - velocity_of(states[i])).norm(), 0.0, 1e-10);
      }
    }
  }
}

TEST(ForwardKinematics, FlippedModuleStatesGiveTheSameTwist) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  ASSERT_EQ(kinematics.inverse({0.4, -0.3, 1.1}, &states), KinematicsStatus::kOk);
  ModuleStates flipped = states;
  flipped[1] = ModuleState{-states[1].speed, wrap_angle(states[1].angle + kPi)};
  flipped[3] = ModuleState{-states[3].speed, wrap_angle(states[3].angle + kPi)};
  Eigen::Vector3d a, b;
  kinematics.forward(states, &a);
  kinematics.forward(flipped, &b);
  EXPECT_NEAR((a - b).norm(), 0.0, 1e-12);
}

TEST(ForwardKinematics, MatchesAnIndependentLeastSquaresSolveOnInconsistentModules) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> value(-2.0, 2.0);
  for (const auto& [name, layout] : layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    ModuleStates states(layout.size());
    for (ModuleState& s : states) s = ModuleState{value(rng), value(rng)};
    Eigen::Vector3d twist;
    ASSERT_EQ(kinematics.forward(states, &twist), KinematicsStatus::kOk);
    const Eigen::Vector3d expected = dense_least_squares(layout, states, Eigen::VectorXd::Ones(layout.size()));
    EXPECT_NEAR((twist - expected).norm(), 0.0, 1e-12);
  }
}

TEST(ForwardKinematics, ClosedFormIsUsedExactlyOnCentredLayoutsAndEqualsLeastSquares) {
  EXPECT_TRUE(Kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05)).uses_closed_form());
  EXPECT_TRUE(Kinematics(ModuleLayout::triangle(0.4, 0.05)).uses_closed_form());
  EXPECT_TRUE(Kinematics(ModuleLayout::multi_axle(4, 0.4, 0.7, 0.05)).uses_closed_form());
  EXPECT_FALSE(Kinematics(ModuleLayout::two_module(0.3, 0.5, 0.05)).uses_closed_form());
  EXPECT_FALSE(Kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05).recentered({0.1, 0.0})).uses_closed_form());
  // Equality on random (inconsistent) module velocities, where any shortcut that is not the
  // least-squares solution would show.
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  for (const ModuleLayout& layout : {ModuleLayout::rectangle(0.6, 0.4, 0.05), ModuleLayout::triangle(0.4, 0.05),
                                     ModuleLayout::multi_axle(4, 0.4, 0.7, 0.05)}) {
    const Kinematics kinematics(layout);
    for (int trial = 0; trial < 50; ++trial) {
      ModuleStates states(layout.size());
      for (ModuleState& s : states) s = ModuleState{value(rng), value(rng)};
      Eigen::Vector3d fast;
      kinematics.forward(states, &fast);
      const Eigen::Vector3d expected = dense_least_squares(layout, states, Eigen::VectorXd::Ones(layout.size()));
      EXPECT_NEAR((fast - expected).norm(), 0.0, 1e-13 * (1.0 + expected.norm()));
    }
  }
}

TEST(ForwardKinematics, ReportsTheTwistOfARecenteredReferencePoint) {
  const ModuleLayout base = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  const Eigen::Vector2d p(0.1, -0.05);
  const Kinematics at_centre(base);
  const Kinematics at_p(base.recentered(p));
  ModuleStates states;
  at_centre.inverse({0.5, 0.2, 0.8}, &states);
  Eigen::Vector3d twist_p;
  ASSERT_EQ(at_p.forward(states, &twist_p), KinematicsStatus::kOk);
  // v_p = v + omega x p = (0.5 - 0.8 * -0.05, 0.2 + 0.8 * 0.1).
  EXPECT_NEAR((twist_p - Eigen::Vector3d(0.54, 0.28, 0.8)).norm(), 0.0, 1e-12);
}

TEST(ForwardKinematics, WeightsDistrustAFaultyModule) {
  const ModuleLayout layout = ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05);
  const Kinematics kinematics(layout);
  const Eigen::Vector3d truth(0.8, -0.3, 0.5);
  ModuleStates states;
  kinematics.inverse(truth, &states);
  states[4] = ModuleState{3.0, 1.0};  // slipping wheel
  ModuleWeights weights(layout.size(), 1.0);
  Eigen::Vector3d plain, weighted;
  ASSERT_EQ(kinematics.forward(states, weights, &plain), KinematicsStatus::kOk);
  Eigen::Vector3d unweighted;
  kinematics.forward(states, &unweighted);
  EXPECT_NEAR((plain - unweighted).norm(), 0.0, 1e-12);  // equal weights = unweighted
  EXPECT_GT((plain - truth).norm(), 0.1);
  weights[4] = 0.0;
  ASSERT_EQ(kinematics.forward(states, weights, &weighted), KinematicsStatus::kOk);
  EXPECT_NEAR((weighted - truth).norm(), 0.0, 1e-12);
  // Intermediate weights match the dense weighted solve.
  weights[4] = 0.25;
  weights[0] = 2.0;
  kinematics.forward(states, weights, &weighted);
  Eigen::VectorXd w(layout.size());
  for (int i = 0; i < layout.size(); ++i) w(i) = weights[i];
  EXPECT_NEAR((weighted - dense_least_squares(layout, states, w)).norm(), 0.0, 1e-12);
}

TEST(ForwardKinematics, WeightsThatLeaveFewerThanTwoModulesAreRankDeficient) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  kinematics.inverse({1.0, 0.0, 0.0}, &states);
  Eigen::Vector3d twist(7.0, 7.0, 7.0);
  ModuleWeights weights(4, 0.0);
  EXPECT_EQ(kinematics.forward(states, weights, &twist), KinematicsStatus::kRankDeficient);
  EXPECT_EQ(twist, Eigen::Vector3d::Zero());
  weights[2] = 1.0;
  EXPECT_EQ(kinematics.forward(states, weights, &twist), KinematicsStatus::kRankDeficient);
  weights[3] = 1.0;
  EXPECT_EQ(kinematics.forward(states, weights, &twist), KinematicsStatus::kOk);
  weights[0] = -1.0;
  EXPECT_EQ(kinematics.forward(states, weights, &twist), KinematicsStatus::kInvalidWeight);
}

TEST(ForwardKinematics, PositionDeltasUseTheSameLeastSquares) {
  const Kinematics kinematics(ModuleLayout::triangle(0.4, 0.05));
  ModuleStates states;
  kinematics.inverse({1.0, 0.5, -0.7}, &states);
  ModulePositions deltas(3);
  for (int i = 0; i < 3; ++i) deltas[i] = ModulePosition{states[i].speed * 0.02, states[i].angle};
  Eigen::Vector3d delta;
  ASSERT_EQ(kinematics.forward_delta(deltas, &delta), KinematicsStatus::kOk);
  EXPECT_NEAR((delta - 0.02 * Eigen::Vector3d(1.0, 0.5, -0.7)).norm(), 0.0, 1e-14);
}

// ---- bad input -------------------------------------------------------------------------------------

TEST(KinematicsBadInput, NonFiniteTwistGivesAStatusAndZeroSpeedsNeverNan) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  EXPECT_EQ(kinematics.inverse({NAN, 0.0, 0.0}, &states), KinematicsStatus::kNonFiniteInput);
  ASSERT_EQ(states.size(), 4);
  for (const ModuleState& s : states) EXPECT_EQ(s.speed, 0.0);
  ModuleHeadingMemory memory(4);
  memory.remember(2, 0.7, 1);
  EXPECT_EQ(kinematics.command({0.0, INFINITY, 0.0}, &memory, &states), KinematicsStatus::kNonFiniteInput);
  EXPECT_EQ(states[2].speed, 0.0);
  EXPECT_DOUBLE_EQ(states[2].angle, 0.7);  // held where it was
}

TEST(KinematicsBadInput, WrongModuleCountInForwardKinematicsIsReported) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  Eigen::Vector3d twist(1.0, 1.0, 1.0);
  EXPECT_EQ(kinematics.forward(ModuleStates(3), &twist), KinematicsStatus::kWrongModuleCount);
  EXPECT_EQ(twist, Eigen::Vector3d::Zero());
  ModuleStates nan_states(4);
  nan_states[1].angle = NAN;
  EXPECT_EQ(kinematics.forward(nan_states, &twist), KinematicsStatus::kNonFiniteInput);
  EXPECT_EQ(kinematics.forward_delta(ModulePositions(5), &twist), KinematicsStatus::kWrongModuleCount);
  ModuleHeadingMemory wrong_memory(3);
  ModuleStates states;
  EXPECT_EQ(kinematics.command({1.0, 0.0, 0.0}, &wrong_memory, &states), KinematicsStatus::kWrongModuleCount);
}

TEST(KinematicsBadInput, TooManyModulesAndInvalidOptionsThrowAtConstruction) {
  EXPECT_THROW(Kinematics(ModuleLayout::multi_axle(9, 0.3, 0.6, 0.05)), ConfigError);
  EXPECT_NO_THROW(Kinematics(ModuleLayout::multi_axle(8, 0.3, 0.6, 0.05)));
  KinematicsOptions options;
  options.flip_hysteresis = 2.0;
  try {
    Kinematics(ModuleLayout::triangle(0.4, 0.05), options);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("flip_hysteresis = 2"), std::string::npos) << error.what();
  }
  options = KinematicsOptions{};
  options.hold_speed_threshold = -1e-3;
  EXPECT_THROW(options.validate(), ConfigError);
}

TEST(KinematicsOptions, LoadFromYamlWithDefaultsAndCheckedValues) {
  const auto root = config::ConfigNode::parse("kinematics: {flip_hysteresis: 0.2, whole_robot_flip: true}\n", "k.yaml");
  const KinematicsOptions options = load_kinematics_options(root.child("kinematics"));
  EXPECT_NO_THROW(root.expect_all_read());
  EXPECT_DOUBLE_EQ(options.flip_hysteresis, 0.2);
  EXPECT_TRUE(options.whole_robot_flip);
  EXPECT_DOUBLE_EQ(options.hold_speed_threshold, KinematicsOptions{}.hold_speed_threshold);
  const auto bad = config::ConfigNode::parse("kinematics: {flip_hysteresis: 1.6}\n", "k.yaml");
  EXPECT_THROW(load_kinematics_options(bad.child("kinematics")), ConfigError);
  const auto typo = config::ConfigNode::parse("kinematics: {flip_hysterisis: 0.1}\n", "k.yaml");
  load_kinematics_options(typo.child("kinematics"));
  EXPECT_THROW(typo.expect_all_read(), ConfigError);
}

TEST(KinematicsOptions, ValidateAcceptsAHysteresisBandUpToButExcludingNinetyDegrees) {
  // The band is the steering error beyond 90 deg a kept decision may reach: at 90 deg it would keep
  // a reversed module forever, so [0, pi/2) is the rule, checked at its edges.
  KinematicsOptions options;
  for (const double band : {0.0, kPi / 2.0 - 1e-9}) {
    options.flip_hysteresis = band;
    EXPECT_NO_THROW(options.validate()) << band;
  }
  for (const double band : {-1e-9, kPi / 2.0, 1.6, 2.0}) {
    options.flip_hysteresis = band;
    EXPECT_THROW(options.validate(), ConfigError) << band;
  }
}

// ---- desaturation ----------------------------------------------------------------------------------

TEST(Desaturate, NeverExceedsTheLimitAndPreservesRatiosAndSigns) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> value(-6.0, 6.0);
  for (int count = 2; count <= 8; ++count) {
    ModuleStates states(count);
    for (ModuleState& s : states) s = ModuleState{value(rng), value(rng)};
    const ModuleStates before = states;
    ASSERT_EQ(Kinematics::desaturate(2.0, &states), KinematicsStatus::kOk);
    double fastest = 0.0;
    for (int i = 0; i < count; ++i) {
      fastest = std::max(fastest, std::abs(states[i].speed));
      EXPECT_EQ(states[i].angle, before[i].angle);
      EXPECT_EQ(std::signbit(states[i].speed), std::signbit(before[i].speed));
      EXPECT_NEAR(states[i].speed * before[0].speed, before[i].speed * states[0].speed, 1e-12);
    }
    EXPECT_LE(fastest, 2.0 + 1e-12);
  }
}

TEST(Desaturate, LeavesFeasibleSpeedsAloneAndRejectsBadLimits) {
  ModuleStates states(3);
  states[0].speed = -1.0;
  states[1].speed = 1.5;
  const ModuleStates before = states;
  ASSERT_EQ(Kinematics::desaturate(2.0, &states), KinematicsStatus::kOk);
  EXPECT_EQ(states[1].speed, before[1].speed);
  EXPECT_EQ(Kinematics::desaturate(-2.0, &states), KinematicsStatus::kInvalidLimit);
  EXPECT_EQ(Kinematics::desaturate(NAN, &states), KinematicsStatus::kInvalidLimit);
  EXPECT_EQ(states[1].speed, before[1].speed);
}

double fastest_module(const Kinematics& kinematics, const Eigen::Vector3d& twist) {
  ModuleStates states;
  kinematics.inverse(twist, &states);
  double fastest = 0.0;
  for (const ModuleState& s : states) fastest = std::max(fastest, s.speed);
  return fastest;
}

TEST(DesaturateTwist, KeepRotationShrinksOnlyTranslationToExactlyTheLimit) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  Eigen::Vector3d out;
  ASSERT_EQ(kinematics.desaturate_twist({3.0, 1.0, 2.0}, 2.0, DesaturationPriority::kKeepRotation, &out),
            KinematicsStatus::kOk);
  EXPECT_DOUBLE_EQ(out.z(), 2.0);
  EXPECT_NEAR(out.x() * 1.0 - out.y() * 3.0, 0.0, 1e-12);  // translation direction kept
  EXPECT_LT(out.head<2>().norm(), std::hypot(3.0, 1.0));
  EXPECT_NEAR(fastest_module(kinematics, out), 2.0, 1e-9);
}

TEST(DesaturateTwist, KeepTranslationShrinksOnlyRotation) {
  const Kinematics kinematics(ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05));
  Eigen::Vector3d out;
  ASSERT_EQ(kinematics.desaturate_twist({1.2, 0.0, 4.0}, 2.0, DesaturationPriority::kKeepTranslation, &out),
            KinematicsStatus::kOk);
  EXPECT_DOUBLE_EQ(out.x(), 1.2);
  EXPECT_DOUBLE_EQ(out.y(), 0.0);
  EXPECT_GT(out.z(), 0.0);
  EXPECT_LT(out.z(), 4.0);
  EXPECT_NEAR(fastest_module(kinematics, out), 2.0, 1e-9);
}

TEST(DesaturateTwist, ProportionalKeepsTheTwistDirectionAndFeasibleTwistsPassUnchanged) {
  const Kinematics kinematics(ModuleLayout::triangle(0.4, 0.05));
  const Eigen::Vector3d command(3.0, -2.0, 5.0);
  Eigen::Vector3d out;
  ASSERT_EQ(kinematics.desaturate_twist(command, 2.0, DesaturationPriority::kProportional, &out),
            KinematicsStatus::kOk);
  EXPECT_NEAR(out.normalized().dot(command.normalized()), 1.0, 1e-12);
  EXPECT_NEAR(fastest_module(kinematics, out), 2.0, 1e-9);
  // Rotation alone too fast under kKeepRotation: falls back to proportional.
  Eigen::Vector3d fallback;
  kinematics.desaturate_twist({0.1, 0.0, 20.0}, 2.0, DesaturationPriority::kKeepRotation, &fallback);
  EXPECT_NEAR(fastest_module(kinematics, fallback), 2.0, 1e-9);
  EXPECT_NEAR(fallback.x() / fallback.z(), 0.1 / 20.0, 1e-12);
  kinematics.desaturate_twist({0.5, 0.1, 0.3}, 2.0, DesaturationPriority::kKeepRotation, &out);
  EXPECT_EQ(out, Eigen::Vector3d(0.5, 0.1, 0.3));
  EXPECT_EQ(kinematics.desaturate_twist(command, 0.0, DesaturationPriority::kProportional, &out),
            KinematicsStatus::kInvalidLimit);
}

// ---- singularity hold and module optimisation ------------------------------------------------------

TEST(SingularityHold, ZeroCommandKeepsEveryRememberedHeading) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates states;
  ASSERT_EQ(kinematics.command({0.0, 0.0, 1.0}, &memory, &states), KinematicsStatus::kOk);
  const ModuleStates spinning = states;
  ASSERT_EQ(kinematics.command({0.0, 0.0, 0.0}, &memory, &states), KinematicsStatus::kOk);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(states[i].speed, 0.0);
    EXPECT_DOUBLE_EQ(states[i].angle, spinning[i].angle);
  }
  memory.reset();
  ASSERT_EQ(kinematics.command({0.0, 0.0, 0.0}, &memory, &states), KinematicsStatus::kOk);
  for (const ModuleState& s : states) EXPECT_EQ(s.angle, 0.0);  // reset: straight ahead
}

TEST(SingularityHold, ModuleAtTheCentreOfRotationKeepsItsHeadingWhileOthersTurn) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates states;
  kinematics.command({1.0, 1.0, 0.0}, &memory, &states);  // all at 45 deg
  ASSERT_EQ(kinematics.command({0.0, 0.0, 1.0}, &memory, &states, {0.3, 0.2}), KinematicsStatus::kOk);
  EXPECT_NEAR(states[0].angle, kPi / 4.0, 1e-12);
  EXPECT_EQ(states[0].speed, 0.0);
  EXPECT_NEAR(states[1].angle, 0.0, 1e-12);
}

TEST(SingularityHold, TinySpeedsKeepHeadingAndProjectTheirVelocity) {
  const Kinematics kinematics(ModuleLayout::triangle(0.4, 0.05));
  ModuleHeadingMemory memory(3);
  ModuleStates measured(3);
  for (ModuleState& m : measured) m.angle = 0.5;
  ASSERT_EQ(memory.reset(measured), KinematicsStatus::kOk);
  ModuleStates states;
  ASSERT_EQ(kinematics.command({0.0, 4e-4, 0.0}, &memory, &states), KinematicsStatus::kOk);
  for (const ModuleState& s : states) {
    EXPECT_DOUBLE_EQ(s.angle, 0.5);
    EXPECT_NEAR(s.speed, 4e-4 * std::sin(0.5), 1e-15);
  }
}

TEST(ModuleOptimization, ReversingCommandDrivesBackwardsInsteadOfTurningAround) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates states;
  kinematics.command({1.0, 0.0, 0.0}, &memory, &states);
  ASSERT_EQ(kinematics.command({-1.0, 0.1, 0.0}, &memory, &states), KinematicsStatus::kOk);
  for (const ModuleState& s : states) {
    EXPECT_LT(s.speed, 0.0);
    EXPECT_NEAR(s.angle, std::atan2(-0.1, 1.0), 1e-12);
  }
  // An 80 deg change is steered, not flipped.
  memory.reset();
  kinematics.command({1.0, 0.0, 0.0}, &memory, &states);
  kinematics.command({std::cos(1.4), std::sin(1.4), 0.0}, &memory, &states);
  for (const ModuleState& s : states) EXPECT_NEAR(s.angle, 1.4, 1e-12);
}

// Counts how often module 0 changes between forward and reversed drive while the command
// direction oscillates slowly around 90 deg from a wheel that stays at angle 0.
int decision_changes(double hysteresis) {
  KinematicsOptions options;
  options.flip_hysteresis = hysteresis;
  options.cosine_scaling = false;
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05), options);
  ModuleHeadingMemory memory(4);
  ModuleStates measured(4);  // steering lags: the wheels stay at 0
  ModuleStates states;
  int changes = 0;
  int previous_sign = 0;
  for (int step = 0; step < 400; ++step) {
    const double direction = kPi / 2.0 + 0.05 * std::sin(2.0 * kPi * step / 100.0);
    kinematics.command({std::cos(direction), std::sin(direction), 0.0}, &memory, &states, {0.0, 0.0}, &measured);
    const int sign = states[0].speed > 0.0 ? 1 : -1;
    if (previous_sign != 0 && sign != previous_sign) ++changes;
    previous_sign = sign;
  }
  return changes;
}

TEST(ModuleOptimization, HysteresisNeverChattersOnASlowlyOscillatingCommand) {
  EXPECT_GT(decision_changes(0.0), 4);  // without a band it chatters (the test can fail)
  EXPECT_EQ(decision_changes(0.1), 0);
}

TEST(ModuleOptimization, HysteresisStillFlipsForADecisiveReversal) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates measured(4);
  ModuleStates states;
  kinematics.command({0.0, 1.0, 0.0}, &memory, &states, {0.0, 0.0}, &measured);
  const int first = states[0].speed > 0.0 ? 1 : -1;
  // Keeping the previous decision would now need 90 deg + 0.3 rad of steering: outside the band.
  const double direction = first > 0 ? kPi / 2.0 + 0.3 : kPi / 2.0 + 0.3 - kPi;
  kinematics.command({std::cos(direction), std::sin(direction), 0.0}, &memory, &states, {0.0, 0.0}, &measured);
  EXPECT_NE(states[0].speed > 0.0 ? 1 : -1, first);
}

// Drive sign of every module after commanding a pure translation at `direction_rad` with the
// wheels measured at angle 0; `previous_direction_rad`, when given, is commanded first so that the
// module already holds a decision (forward at 0). Cosine scaling is off so the sign is the speed's.
std::vector<int> drive_signs(double hysteresis, double direction_rad, bool whole_robot = false,
                             const double* previous_direction_rad = nullptr) {
  KinematicsOptions options;
  options.flip_hysteresis = hysteresis;
  options.cosine_scaling = false;
  options.whole_robot_flip = whole_robot;
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05), options);
  ModuleHeadingMemory memory(4);
  ModuleStates measured(4);  // all at angle 0
  ModuleStates states;
  if (previous_direction_rad != nullptr) {
    const double d = *previous_direction_rad;
    kinematics.command({std::cos(d), std::sin(d), 0.0}, &memory, &states, {0.0, 0.0}, &measured);
  }
  kinematics.command({std::cos(direction_rad), std::sin(direction_rad), 0.0}, &memory, &states, {0.0, 0.0},
                     &measured);
  std::vector<int> signs;
  for (const ModuleState& s : states) signs.push_back(s.speed > 0.0 ? 1 : -1);
  return signs;
}

constexpr double kDegree = kPi / 180.0;
const std::vector<int> kAllForward = {1, 1, 1, 1};
const std::vector<int> kAllReversed = {-1, -1, -1, -1};

TEST(ModuleOptimization, FirstDecisionFlipsExactlyBeyondNinetyDegrees) {
  // No previous decision: the module drives forward while the steering error is below 90 deg and
  // reversed above it, whatever the band (the band applies only to keeping a decision). 1 deg on
  // either side pins the threshold to within 1 deg.
  for (const double hysteresis : {0.0, 0.1}) {
    SCOPED_TRACE(hysteresis);
    EXPECT_EQ(drive_signs(hysteresis, 89.0 * kDegree), kAllForward);
    EXPECT_EQ(drive_signs(hysteresis, 91.0 * kDegree), kAllReversed);
    EXPECT_EQ(drive_signs(hysteresis, -89.0 * kDegree), kAllForward);
    EXPECT_EQ(drive_signs(hysteresis, -91.0 * kDegree), kAllReversed);
  }
}

TEST(ModuleOptimization, WholeRobotFirstDecisionFlipsExactlyBeyondNinetyDegrees) {
  EXPECT_EQ(drive_signs(0.1, 89.0 * kDegree, true), kAllForward);
  EXPECT_EQ(drive_signs(0.1, 91.0 * kDegree, true), kAllReversed);
}

TEST(ModuleOptimization, AKeptDecisionFlipsExactlyAtTheHysteresisEdge) {
  // Forward at 0 first; keeping forward then costs a steering error equal to the new direction, and
  // is allowed up to 90 deg + band. 0.5 deg on either side of the edge pins it to within 0.5 deg.
  const double ahead = 0.0;
  for (const bool whole_robot : {false, true}) {
    SCOPED_TRACE(whole_robot ? "whole robot" : "per module");
    for (const double hysteresis : {0.0, 0.1, 0.3}) {
      SCOPED_TRACE(hysteresis);
      const double edge = kPi / 2.0 + hysteresis;
      EXPECT_EQ(drive_signs(hysteresis, edge - 0.5 * kDegree, whole_robot, &ahead), kAllForward);
      EXPECT_EQ(drive_signs(hysteresis, edge + 0.5 * kDegree, whole_robot, &ahead), kAllReversed);
      EXPECT_EQ(drive_signs(hysteresis, -(edge - 0.5 * kDegree), whole_robot, &ahead), kAllForward);
      EXPECT_EQ(drive_signs(hysteresis, -(edge + 0.5 * kDegree), whole_robot, &ahead), kAllReversed);
    }
  }
}

TEST(ModuleOptimization, AReversedDecisionIsKeptUpToTheHysteresisEdgeToo) {
  // Reversed first (command at 180 deg from wheels at 0); keeping it reversed costs a steering
  // error of 180 deg minus the new direction, allowed up to 90 deg + band.
  const double behind = kPi;
  const double hysteresis = 0.2;
  const double edge = kPi / 2.0 - hysteresis;  // direction at which the reversed error is 90 + band
  EXPECT_EQ(drive_signs(hysteresis, edge + 0.5 * kDegree, false, &behind), kAllReversed);
  EXPECT_EQ(drive_signs(hysteresis, edge - 0.5 * kDegree, false, &behind), kAllForward);
}

TEST(ModuleOptimization, CommandNeverTurnsAModulePastAnEndStop) {
  // Modules limited to +-90 deg, steered to 1.5 rad; the twist points at pi - 0.2 rad. That heading
  // is the nearer way round (1.44 rad of turn) but past the stop, so the modules reverse to -0.2 rad
  // and drive backwards. (Before the shared map, command() ignored the end stops and sent 2.94 rad.)
  ModuleLimits limits;
  limits.min_steering_angle = -kPi / 2;
  limits.max_steering_angle = kPi / 2;
  KinematicsOptions options;
  options.cosine_scaling = false;  // a 1.7 rad turn would scale the speed to 0
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05, limits), options);
  ModuleStates measured(4);
  for (ModuleState& m : measured) m.angle = 1.5;
  ModuleHeadingMemory memory(4);
  memory.reset(measured);
  ModuleStates states;
  const double heading = kPi - 0.2;
  ASSERT_EQ(kinematics.command({std::cos(heading), std::sin(heading), 0.0}, &memory, &states, {0.0, 0.0}, &measured),
            KinematicsStatus::kOk);
  for (const ModuleState& s : states) {
    EXPECT_NEAR(s.angle, -0.2, 1e-12);
    EXPECT_LT(s.speed, 0.0);
  }
}

TEST(ModuleOptimization, WholeRobotModeFlipsAllModulesTogether) {
  // Twist (0.2, 0, 2) from wheels at 0: FL/RL want 108 deg (flip alone), FR/RR 45 deg.
  KinematicsOptions per_module;
  per_module.cosine_scaling = false;
  KinematicsOptions whole = per_module;
  whole.whole_robot_flip = true;
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  ModuleStates measured(4);
  for (const auto& [options, expect_mixed] : {std::pair{per_module, true}, std::pair{whole, false}}) {
    const Kinematics kinematics(layout, options);
    ModuleHeadingMemory memory(4);
    memory.reset(measured);
    ModuleStates states;
    ASSERT_EQ(kinematics.command({0.2, 0.0, 2.0}, &memory, &states, {0.0, 0.0}, &measured), KinematicsStatus::kOk);
    int reversed = 0;
    for (const ModuleState& s : states) reversed += s.speed < 0.0 ? 1 : 0;
    if (expect_mixed) {
      EXPECT_EQ(reversed, 2);
    } else {
      EXPECT_TRUE(reversed == 0 || reversed == 4) << reversed;
    }
    Eigen::Vector3d twist;  // either way the commanded motion is the same
    kinematics.forward(states, &twist);
    EXPECT_NEAR((twist - Eigen::Vector3d(0.2, 0.0, 2.0)).norm(), 0.0, 1e-12);
  }
}

TEST(ModuleOptimization, CosineScalingSlowsModulesThatAreStillSteering) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates measured(4);
  for (ModuleState& m : measured) m.angle = kPi / 3.0;  // 60 deg away from the command
  ModuleStates states;
  ASSERT_EQ(kinematics.command({1.0, 0.0, 0.0}, &memory, &states, {0.0, 0.0}, &measured), KinematicsStatus::kOk);
  for (const ModuleState& s : states) {
    EXPECT_NEAR(s.speed, 0.5, 1e-12);
    EXPECT_NEAR(s.angle, 0.0, 1e-12);
  }
}

TEST(ModuleOptimization, CosineScalingOfAReversedModuleUsesTheReversedSteeringError) {
  // Wheels measured at 0, command at 150 deg: the module reverses (drives at -30 deg), whose
  // steering error is 30 deg, so the speed is scaled by cos 30 deg, not by cos 150 deg < 0 (-> 0).
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleHeadingMemory memory(4);
  ModuleStates measured(4);
  ModuleStates states;
  const double direction = 150.0 * kPi / 180.0;
  ASSERT_EQ(kinematics.command({std::cos(direction), std::sin(direction), 0.0}, &memory, &states, {0.0, 0.0},
                               &measured),
            KinematicsStatus::kOk);
  for (const ModuleState& s : states) {
    // Tolerance: a few products of unit-size doubles; 1e-12 is rounding.
    EXPECT_NEAR(s.speed, -std::cos(kPi / 6.0), 1e-12);
    EXPECT_NEAR(s.angle, -kPi / 6.0, 1e-12);
  }
}

// ---- second order ----------------------------------------------------------------------------------

TEST(SecondOrderKinematics, MatchesFiniteDifferencesOfFirstOrderForTwoToEightModules) {
  std::mt19937 rng(21);
  const double dt = 1e-6;
  for (const auto& [name, layout] : layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Vector3d twist = random_twist(rng);
      const Eigen::Vector3d twist_rate = random_twist(rng);
      ModuleStates now, before, after;
      kinematics.inverse(twist, &now);
      bool well_conditioned = true;
      for (const ModuleState& s : now) well_conditioned = well_conditioned && s.speed > 0.2;
      if (!well_conditioned) continue;
      kinematics.inverse(twist - dt * twist_rate, &before);
      kinematics.inverse(twist + dt * twist_rate, &after);
      ModuleAccelerations accelerations;
      ASSERT_EQ(kinematics.second_order(twist, Kinematics::inertial_acceleration(twist, twist_rate), now,
                                        &accelerations),
                KinematicsStatus::kOk);
      for (int i = 0; i < layout.size(); ++i) {
        const double drive_fd = (after[i].speed - before[i].speed) / (2.0 * dt);
        const double steer_fd = wrap_angle(after[i].angle - before[i].angle) / (2.0 * dt);
        EXPECT_NEAR(accelerations[i].drive_acceleration, drive_fd, 1e-6 * (1.0 + std::abs(drive_fd)));
        EXPECT_NEAR(accelerations[i].steering_rate, steer_fd, 1e-6 * (1.0 + std::abs(steer_fd)));
      }
    }
  }
}

TEST(SecondOrderKinematics, SpinAtConstantRateHasCentripetalModuleAccelerationButNoDriveOrSteering) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  const Kinematics kinematics(layout);
  const Eigen::Vector3d twist(0.0, 0.0, 3.0);
  ModuleStates states;
  kinematics.inverse(twist, &states);
  ModuleAccelerations accelerations;
  ASSERT_EQ(kinematics.second_order(twist, Kinematics::inertial_acceleration(twist, Eigen::Vector3d::Zero()),
                                    states, &accelerations),
            KinematicsStatus::kOk);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR((accelerations[i].acceleration_body + 9.0 * layout.position_body(i)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(accelerations[i].drive_acceleration, 0.0, 1e-12);
    EXPECT_NEAR(accelerations[i].steering_rate, 0.0, 1e-12);
  }
}

TEST(SecondOrderKinematics, ModuleAtStandstillGetsFiniteZeroSteeringRate) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states(4);  // all stopped at angle 0
  ModuleAccelerations accelerations;
  ASSERT_EQ(kinematics.second_order(Eigen::Vector3d::Zero(), {0.0, 2.0, 1.0}, states, &accelerations),
            KinematicsStatus::kOk);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(accelerations[i].steering_rate, 0.0);
    // Drive acceleration: the acceleration projected on the held heading (x): -alpha * y_i.
    EXPECT_NEAR(accelerations[i].drive_acceleration, -1.0 * kinematics.layout().position_body(i).y(), 1e-12);
  }
  // Approaching zero speed the steering rate stays bounded (ramped below the hold threshold).
  for (double speed : {1e-2, 1e-3, 5e-4, 1e-6, 0.0}) {
    ModuleStates slow(4);
    kinematics.second_order({speed, 0.0, 0.0}, {0.0, 1.0, 0.0}, slow, &accelerations);
    const double bound = 1.0 / kinematics.options().hold_speed_threshold;
    EXPECT_LE(std::abs(accelerations[0].steering_rate), bound + 1e-9) << speed;
    EXPECT_TRUE(std::isfinite(accelerations[0].steering_rate));
  }
}

TEST(SecondOrderKinematics, ChassisAccelerationInvertsSecondOrderIncludingFlippedModules) {
  std::mt19937 rng(4);
  for (int count = 2; count <= 8; ++count) {
    const Kinematics kinematics(random_layout(count, rng));
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Vector3d twist = random_twist(rng);
      const Eigen::Vector3d acceleration = random_twist(rng);
      ModuleStates states;
      kinematics.inverse(twist, &states);
      bool moving = true;
      for (const ModuleState& s : states) moving = moving && s.speed > 0.05;
      if (!moving) continue;
      states[0] = ModuleState{-states[0].speed, wrap_angle(states[0].angle + kPi)};
      ModuleAccelerations accelerations;
      ASSERT_EQ(kinematics.second_order(twist, acceleration, states, &accelerations), KinematicsStatus::kOk);
      Eigen::Vector3d recovered;
      ASSERT_EQ(kinematics.chassis_acceleration(states, accelerations, &recovered), KinematicsStatus::kOk);
      EXPECT_NEAR((recovered - acceleration).norm(), 0.0, 1e-9) << count;
    }
  }
}

TEST(SecondOrderKinematics, BadInputGivesStatusAndZeros) {
  const Kinematics kinematics(ModuleLayout::triangle(0.4, 0.05));
  ModuleAccelerations accelerations;
  EXPECT_EQ(kinematics.second_order({1.0, 0.0, 0.0}, {NAN, 0.0, 0.0}, ModuleStates(3), &accelerations),
            KinematicsStatus::kNonFiniteInput);
  for (const ModuleAcceleration& a : accelerations) EXPECT_EQ(a.steering_rate, 0.0);
  EXPECT_EQ(kinematics.second_order({1.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, ModuleStates(4), &accelerations),
            KinematicsStatus::kWrongModuleCount);
}

TEST(SecondOrderKinematics, AboutACentreOfRotationItIsTheSameMotionTransferredToTheOrigin) {
  // Twist and acceleration of the body point c; the origin o = c + d (d = -c) then moves with
  // v_o = v_c + omega x d and accelerates with a_o = a_c + alpha x d - omega^2 d (rigid body).
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  const Eigen::Vector2d c(0.4, -0.2), d = -c;
  const Eigen::Vector3d twist_c(0.5, 0.1, 0.8), accel_c(0.3, -0.2, 1.5);
  const double omega = twist_c.z(), alpha = accel_c.z();
  const Eigen::Vector3d twist_o(twist_c.x() - omega * d.y(), twist_c.y() + omega * d.x(), omega);
  const Eigen::Vector3d accel_o(accel_c.x() - alpha * d.y() - omega * omega * d.x(),
                                accel_c.y() + alpha * d.x() - omega * omega * d.y(), alpha);
  ModuleStates states(4);
  ASSERT_EQ(kinematics.inverse(twist_c, &states, c), KinematicsStatus::kOk);
  ModuleAccelerations about_c(4), about_o(4);
  ASSERT_EQ(kinematics.second_order(twist_c, accel_c, states, &about_c, c), KinematicsStatus::kOk);
  ASSERT_EQ(kinematics.second_order(twist_o, accel_o, states, &about_o), KinematicsStatus::kOk);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(about_c[i].drive_acceleration, about_o[i].drive_acceleration, 1e-12) << "module " << i;
    EXPECT_NEAR(about_c[i].steering_rate, about_o[i].steering_rate, 1e-12) << "module " << i;
  }
  const Eigen::Vector2d not_finite(std::numeric_limits<double>::quiet_NaN(), 0.0);
  EXPECT_EQ(kinematics.second_order(twist_c, accel_c, states, &about_c, not_finite), KinematicsStatus::kNonFiniteInput);
}

TEST(OptimizeModule, FlipsOnlyWhenTheDesiredAngleIsMoreThanNinetyDegreesAway) {
  const double deg = kPi / 180.0;
  const ModuleState flipped = optimize_module(ModuleState{2.0, 170 * deg}, 0.0);
  EXPECT_NEAR(flipped.speed, -2.0, 1e-15);
  EXPECT_NEAR(flipped.angle, -10 * deg, 1e-12);
  const ModuleState kept = optimize_module(ModuleState{2.0, 80 * deg}, 0.0);
  EXPECT_EQ(kept.speed, 2.0);
  EXPECT_NEAR(kept.angle, 80 * deg, 1e-15);
  EXPECT_EQ(optimize_module(ModuleState{1.0, kPi / 2.0}, 0.0).speed, 1.0);  // exactly 90 deg: kept
  // Across the +-pi seam: at 175 deg, a desired -170 deg is 15 deg away, not 345.
  EXPECT_EQ(optimize_module(ModuleState{1.0, -170 * deg}, 175 * deg).speed, 1.0);
  const ModuleState across = optimize_module(ModuleState{1.0, 10 * deg}, 175 * deg);
  EXPECT_EQ(across.speed, -1.0);
  EXPECT_NEAR(across.angle, -170 * deg, 1e-12);
}

TEST(Kinematics, InverseAndForwardByValueRoundTripAndGiveNothingOnBadInput) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  const Eigen::Vector3d twist(0.7, -0.2, 0.4);
  const std::optional<ModuleStates> states = kinematics.inverse(twist);
  ASSERT_TRUE(states.has_value());
  ASSERT_EQ(states->size(), 4);
  const std::optional<Eigen::Vector3d> back = kinematics.forward(*states);
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR((*back - twist).norm(), 0.0, 1e-12);
  EXPECT_FALSE(kinematics.inverse(Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0)).has_value());
  EXPECT_FALSE(kinematics.forward(ModuleStates(3)).has_value());
}

TEST(ModuleArray, BraceInitialisesOneEntryPerModule) {
  const ModuleStates states{{1.0, 0.1}, {2.0, -0.3}};
  ASSERT_EQ(states.size(), 2);
  EXPECT_EQ(states[1].speed, 2.0);
  EXPECT_EQ(states[1].angle, -0.3);
  const ModuleArray<double> one{4.0};
  EXPECT_EQ(one.size(), 1);
  EXPECT_EQ(ModuleArray<double>(4).size(), 4);
  EXPECT_THROW((ModuleArray<int>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17}), ConfigError);
}

}  // namespace
}  // namespace swerve
