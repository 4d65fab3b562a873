// The twist -> module command map (kinematics/module_commands.hpp): the rigid-body point velocity
// by hand and by its invariant, the way round under each flip policy and the end stops, the rate
// limit and the cosine scaling, the singularity hold, and the smooth map's Jet derivative against
// central differences.
#include "swerve/kinematics/module_commands.hpp"

#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <algorithm>
#include <cmath>

#include "swerve/kinematics/kinematics.hpp"

namespace swerve {
namespace {

ModuleLimits limits_with_end_stops(double half_range) {
  ModuleLimits limits;
  limits.min_steering_angle = -half_range;
  limits.max_steering_angle = half_range;
  return limits;
}

TEST(PointVelocity, IsTheOriginsVelocityPlusTheRotationsAtThePoint) {
  // Turning at 2 rad/s, the point 1 m ahead moves 2 m/s to the left; 1 m to the left, 2 m/s back.
  EXPECT_EQ(point_velocity<double>(0.0, 0.0, 2.0, Eigen::Vector2d(1.0, 0.0)), Eigen::Vector2d(0.0, 2.0));
  EXPECT_EQ(point_velocity<double>(0.0, 0.0, 2.0, Eigen::Vector2d(0.0, 1.0)), Eigen::Vector2d(-2.0, 0.0));
  EXPECT_EQ(point_velocity<double>(Eigen::Vector3d(0.5, -0.25, 0.0), Eigen::Vector2d(3.0, 4.0)),
            Eigen::Vector2d(0.5, -0.25));
}

TEST(PointVelocity, TwoPointsOfARigidBodyMoveEquallyAlongTheLineJoiningThem) {
  const Eigen::Vector3d twist(0.7, -0.3, 1.3);
  const Eigen::Vector2d a(0.4, -1.1), b(-2.0, 0.6);
  const Eigen::Vector2d line = (b - a).normalized();
  EXPECT_NEAR(point_velocity<double>(twist, a).dot(line), point_velocity<double>(twist, b).dot(line), 1e-15);
}

TEST(RollingSpeed, IsTheVelocitysComponentAlongTheWheel) {
  EXPECT_NEAR(rolling_speed<double>(Eigen::Vector2d(1.0, 1.0), kPi / 4), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(rolling_speed<double>(Eigen::Vector2d(0.0, 1.0), 0.0), 0.0, 1e-15);
  EXPECT_NEAR(rolling_speed<double>(Eigen::Vector2d(2.0, 0.0), kPi), -2.0, 1e-15);
}

TEST(ChooseDriveDirection, TheNearestWayRoundFlipsOnlyBeyondAQuarterTurn) {
  const ModuleLimits free_turning;
  const auto keep = choose_drive_direction<double>(1.4, 0.0, 0, FlipPolicy::kNearest, 0.0, free_turning);
  EXPECT_EQ(keep.sign, 1);
  EXPECT_NEAR(keep.turn, 1.4, 1e-15);
  EXPECT_NEAR(keep.other_turn, 1.4 - kPi, 1e-15);
  const auto flip = choose_drive_direction<double>(1.8, 0.0, 0, FlipPolicy::kNearest, 0.0, free_turning);
  EXPECT_EQ(flip.sign, -1);
  EXPECT_NEAR(flip.turn, 1.8 - kPi, 1e-15);
  // The turn is wrapped: from 3 rad to -3 rad is 0.28 rad through pi, not 6 rad back.
  const auto across = choose_drive_direction<double>(-3.0, 3.0, 0, FlipPolicy::kNearest, 0.0, free_turning);
  EXPECT_EQ(across.sign, 1);
  EXPECT_NEAR(across.turn, 2 * kPi - 6.0, 1e-14);
  // kNearest ignores the previous decision.
  EXPECT_EQ(choose_drive_direction<double>(0.2, 0.0, -1, FlipPolicy::kNearest, 0.1, free_turning).sign, 1);
}

constexpr double kTie = kDirectionTieBand;  // the prediction's tie band

TEST(ChooseDriveDirection, ANearTieKeepsTheForwardWayRoundSoModulesOfOneVehicleChooseAlike) {
  // A crab started with the wheels straight: every module's contact velocity points about 90 deg
  // from its wheel, on either side of 90 deg by the twist's small yaw. Choosing by those digits,
  // modules split and turned opposite ways with their wheels driving; inside kDirectionTieBand
  // they all keep the forward way round.
  const ModuleLimits free_turning;
  for (const double off : {-0.05, -1e-9, 0.0, 1e-9, 0.05}) {
    SCOPED_TRACE(off);
    const auto d =
        choose_drive_direction<double>(-kPi / 2 + off, 0.0, 0, FlipPolicy::kNearest, 0.0, free_turning, 0.0, kTie);
    EXPECT_EQ(d.sign, 1);
    EXPECT_NEAR(d.turn, -kPi / 2 + off, 1e-15);
  }
  // Past the band the nearer way round wins, as before.
  EXPECT_EQ(choose_drive_direction<double>(-kPi / 2 - 0.2, 0.0, 0, FlipPolicy::kNearest, 0.0, free_turning, 0.0, kTie)
                .sign,
            -1);
  // Without a tie band (hardware setpoints, WPILib's rule) 0.05 rad past 90 deg flips.
  EXPECT_EQ(choose_drive_direction<double>(-kPi / 2 - 0.05, 0.0, 0, FlipPolicy::kNearest, 0.0, free_turning).sign, -1);
}

TEST(ChooseDriveDirection, AHeadingJustPastAnEndStopIsSteeredToTheStopNotFlipped) {
  // +-90 deg steering, crabbing at -90 deg: a heading 0.05 rad past the -90 deg stop is taken at
  // the stop, the way round a heading 0.05 rad inside it takes, so the two modules of a vehicle
  // whose twist yaws a little do not split between the stops.
  const ModuleLimits limits = limits_with_end_stops(kPi / 2);
  for (const double off : {-0.05, 0.0, 0.05}) {
    SCOPED_TRACE(off);
    const auto d = choose_drive_direction<double>(-kPi / 2 + off, 0.0, 0, FlipPolicy::kNearest, 0.0, limits, 0.0, kTie);
    EXPECT_EQ(d.sign, 1);
    EXPECT_NEAR(d.turn, std::max(-kPi / 2 + off, -kPi / 2), 1e-15);
  }
  // Well past the stop (beyond the band) the module reverses to the reachable heading.
  const auto far = choose_drive_direction<double>(-kPi / 2 - 0.3, 0.0, 0, FlipPolicy::kNearest, 0.0, limits, 0.0, kTie);
  EXPECT_EQ(far.sign, -1);
  EXPECT_NEAR(far.turn, kPi / 2 - 0.3, 1e-15);
}

TEST(ChooseDriveDirection, HysteresisKeepsThePreviousWayRoundInsideTheBand) {
  const ModuleLimits free_turning;
  const double band = 0.1;
  // Reversed before; the reversed heading is now 95 deg away (inside 90 + band): kept, in the band.
  const double heading = kPi / 2 - 5.0 * kPi / 180.0;  // forward: 85 deg; reversed: -95 deg
  const auto kept = choose_drive_direction<double>(heading, 0.0, -1, FlipPolicy::kHysteresis, band, free_turning);
  EXPECT_EQ(kept.sign, -1);
  EXPECT_TRUE(kept.in_band);
  EXPECT_NEAR(kept.turn, heading - kPi, 1e-15);
  // Past 90 deg + band it flips, and is no longer in the band.
  const double far = kPi / 2 - 0.2;
  const auto flipped = choose_drive_direction<double>(far, 0.0, -1, FlipPolicy::kHysteresis, band, free_turning);
  EXPECT_EQ(flipped.sign, 1);
  EXPECT_FALSE(flipped.in_band);
  // A widening moves the flip further out.
  EXPECT_EQ(choose_drive_direction<double>(far, 0.0, -1, FlipPolicy::kHysteresis, band, free_turning, 0.2).sign, -1);
  // Well inside a quarter turn: kept and not in the band.
  const auto easy = choose_drive_direction<double>(0.3, 0.0, 1, FlipPolicy::kHysteresis, band, free_turning);
  EXPECT_EQ(easy.sign, 1);
  EXPECT_FALSE(easy.in_band);
  // No decision yet: the nearest way round.
  EXPECT_EQ(choose_drive_direction<double>(2.0, 0.0, 0, FlipPolicy::kHysteresis, band, free_turning).sign, -1);
}

TEST(ChooseDriveDirection, NeverTurnsPastAnEndStopWhileTheOtherWayRoundIsReachable) {
  const ModuleLimits limits = limits_with_end_stops(kPi / 2);
  // At 1.5 rad, a heading of pi - 0.2 is the nearer (1.44 rad of turn) but past the +90 deg stop:
  // the module reverses to -0.2 rad instead, turning back through 0 (1.7 rad), unwrapped.
  for (const FlipPolicy policy : {FlipPolicy::kNearest, FlipPolicy::kHysteresis}) {
    const auto d = choose_drive_direction<double>(kPi - 0.2, 1.5, 1, policy, 0.1, limits);
    EXPECT_EQ(d.sign, -1);
    EXPECT_NEAR(d.turn, -0.2 - 1.5, 1e-15);
    EXPECT_FALSE(d.in_band);
  }
  // Without end stops the same module keeps the near way round.
  EXPECT_EQ(choose_drive_direction<double>(kPi - 0.2, 1.5, 1, FlipPolicy::kNearest, 0.1, ModuleLimits{}).sign, 1);
}

TEST(ChooseDriveDirection, AShorterEndStopHoldSwingsAModuleWhoseHeadingLiesFurtherPastTheStop) {
  // The pre-alignment's at-rest rule holds at the stop only within the direction's uncertainty: a
  // heading 0.3 rad past the +90 deg stop is held by kEndStopHold but taken the other way round
  // (driven reversed, at 0.3 - 90 deg) with a hold of 0.2 rad.
  const ModuleLimits limits = limits_with_end_stops(kPi / 2);
  const double heading = kPi / 2 + 0.3;
  const auto held = choose_drive_direction<double>(heading, kPi / 2, 1, FlipPolicy::kHysteresis, 0.1, limits);
  EXPECT_EQ(held.sign, 1);
  EXPECT_NEAR(held.turn, 0.0, 1e-15);
  const auto swung =
      choose_drive_direction<double>(heading, kPi / 2, 1, FlipPolicy::kHysteresis, 0.1, limits, 0.0, 0.0, 0.2);
  EXPECT_EQ(swung.sign, -1);
  EXPECT_NEAR(swung.turn, (heading - kPi) - kPi / 2, 1e-12);
}

TEST(ChooseDriveDirection, HysteresisHoldsAModuleAtItsEndStopWhileItsHeadingWandersJustPastIt) {
  // Crabbing at 90 deg on +-90 deg steering: the heading sits at the stop, on either side of it by
  // the measurement's noise and the tracking's corrections. A module driving forward at the +90 deg
  // stop stays there (its turn to the stop is what is left) for headings up to kEndStopHold past
  // it, instead of swinging half a turn to the -90 deg stop; only beyond does the other way round
  // take over.
  const ModuleLimits limits = limits_with_end_stops(kPi / 2);
  const double band = 0.1;
  for (const double past : {1e-9, 0.01, 0.05, 0.3, kEndStopHold - 0.01}) {
    SCOPED_TRACE(past);
    const auto held = choose_drive_direction<double>(kPi / 2 + past, kPi / 2, 1, FlipPolicy::kHysteresis, band, limits);
    EXPECT_EQ(held.sign, 1);
    EXPECT_NEAR(held.turn, 0.0, 1e-15);
    const auto reversed =
        choose_drive_direction<double>(-kPi / 2 - past + kPi, -kPi / 2, -1, FlipPolicy::kHysteresis, band, limits);
    EXPECT_EQ(reversed.sign, -1);  // the same hold at the -90 deg stop, driving reversed
    EXPECT_NEAR(reversed.turn, 0.0, 1e-15);
  }
  // From straight ahead, a heading just past the stop is still steered to the stop the module's way
  // round keeps, and stays open to the coordination of modules in the band.
  const auto start = choose_drive_direction<double>(kPi / 2 + 0.01, 0.0, 1, FlipPolicy::kHysteresis, band, limits);
  EXPECT_EQ(start.sign, 1);
  EXPECT_NEAR(start.turn, kPi / 2, 1e-15);
  EXPECT_TRUE(start.in_band);
  // Beyond the hold the other way round takes over, as before.
  const auto beyond =
      choose_drive_direction<double>(kPi / 2 + kEndStopHold + 0.05, kPi / 2, 1, FlipPolicy::kHysteresis, band, limits);
  EXPECT_EQ(beyond.sign, -1);
  // kNearest without a tie band keeps its strict rule: never a heading past the stop. With the
  // prediction's tie band a heading that close past the stop is held at it.
  EXPECT_EQ(choose_drive_direction<double>(kPi / 2 + 0.01, kPi / 2, 1, FlipPolicy::kNearest, band, limits).sign, -1);
  const auto tied = choose_drive_direction<double>(kPi / 2 + 0.01, kPi / 2, 1, FlipPolicy::kNearest, band, limits, 0.0,
                                                   kDirectionTieBand);
  EXPECT_EQ(tied.sign, 1);
  EXPECT_NEAR(tied.turn, 0.0, 1e-15);
}

TEST(ChooseDriveDirection, WithWideEndStopsTakesTheShorterTurnEvenBeyondAQuarterTurn) {
  // Stops at +-3 rad: from -2.5 rad, a heading of -0.5 rad is 2.0 rad away; its reverse (2.64 rad)
  // is reachable too, but 5.14 rad away the other way round (no turning through +-pi). Both turns
  // exceed 90 deg, so the shorter one is kept, by either policy, whatever was driven before.
  const ModuleLimits limits = limits_with_end_stops(3.0);
  for (const FlipPolicy policy : {FlipPolicy::kNearest, FlipPolicy::kHysteresis}) {
    for (const int previous : {1, 0}) {
      const auto d = choose_drive_direction<double>(-0.5, -2.5, previous, policy, 0.1, limits);
      EXPECT_EQ(d.sign, 1) << "previous " << previous;
      EXPECT_NEAR(d.turn, 2.0, 1e-15);
      EXPECT_NEAR(d.other_turn, kPi - 0.5 + 2.5, 1e-14);
    }
  }
  // Driven reversed before: kept while its turn is the shorter.
  const auto reversed = choose_drive_direction<double>(2.5, -2.5, -1, FlipPolicy::kHysteresis, 0.1, limits);
  EXPECT_EQ(reversed.sign, -1);  // reverse -0.64 rad: 1.86 rad of turn against 5.0 forward
  EXPECT_NEAR(reversed.turn, 2.5 - kPi + 2.5, 1e-14);
}

TEST(SteeringRateToward, MakesTheTurnWithinTheLimitAndSmoothOnlyNearIt) {
  ModuleLimits limits;
  limits.max_steering_rate = 2.0;
  EXPECT_DOUBLE_EQ(steering_rate_toward<double>(0.05, 0.1, limits, LimitShape::kHard), 0.5);
  EXPECT_DOUBLE_EQ(steering_rate_toward<double>(0.5, 0.1, limits, LimitShape::kHard), 2.0);
  EXPECT_DOUBLE_EQ(steering_rate_toward<double>(-0.5, 0.1, limits, LimitShape::kHard), -2.0);
  EXPECT_DOUBLE_EQ(steering_rate_toward<double>(0.05, 0.1, limits, LimitShape::kSmooth), 0.5);
  EXPECT_DOUBLE_EQ(steering_rate_toward<double>(0.5, 0.1, limits, LimitShape::kSmooth), 2.0);
  // At the limit itself the blend (width 10 % of the limit) sits a quarter width inside.
  EXPECT_NEAR(steering_rate_toward<double>(0.2, 0.1, limits, LimitShape::kSmooth), 2.0 - 0.05, 1e-12);
}

TEST(DriveWheelSpeed, ScalesByTheSteeringLeftAndStopsBeyondAQuarterTurn) {
  ModuleLimits limits;
  limits.max_drive_speed = 3.0;
  const double radius = 0.1;
  EXPECT_NEAR(drive_wheel_speed<double>(1.0, kPi / 3, true, limits, radius, LimitShape::kHard), 5.0, 1e-12);
  EXPECT_EQ(drive_wheel_speed<double>(1.0, 2.0, true, limits, radius, LimitShape::kHard), 0.0);
  EXPECT_EQ(drive_wheel_speed<double>(-1.0, 2.0, false, limits, radius, LimitShape::kHard), -10.0);
  EXPECT_EQ(drive_wheel_speed<double>(5.0, 0.0, true, limits, radius, LimitShape::kHard), 30.0);  // the drive limit
}

TEST(ModuleCommands, DriveEveryModuleAlongItsIkVelocityWhenAlreadyAligned) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.5, 0.1);
  const Kinematics kinematics(layout);
  const Eigen::Vector3d twist(0.4, 0.1, 0.3);
  const ModuleStates ik = *kinematics.inverse(twist);
  Eigen::VectorXd angles(4), inputs(8);
  for (int i = 0; i < 4; ++i) angles[i] = ik[i].angle;
  ModuleCommandRule rule;
  module_commands<double>(layout, twist, angles, 0.05, rule, inputs);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(inputs[2 * i], 0.0, 1e-12) << "module " << i;
    EXPECT_NEAR(inputs[2 * i + 1], ik[i].speed / 0.1, 1e-12) << "module " << i;
  }
}

TEST(ModuleCommands, HoldAModuleBelowTheHoldSpeedAndRollItWithItsVelocityAlongItsHeading) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.5, 0.1);
  const Eigen::Vector3d twist(4e-4, 3e-4, 0.0);  // 0.5 mm/s at every module
  const Eigen::VectorXd angles = Eigen::VectorXd::Constant(4, kPi / 2);
  Eigen::VectorXd inputs(8);
  int signs[4];
  ModuleCommandRule rule;
  module_commands<double>(layout, twist, angles, 0.05, rule, inputs, nullptr, signs);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(inputs[2 * i], 0.0);
    EXPECT_NEAR(inputs[2 * i + 1], 3e-4 / 0.1, 1e-15);  // the velocity's y component
    EXPECT_EQ(signs[i], 0);
  }
}

TEST(ModuleCommands, TheSmoothMapsJetDerivativeMatchesCentralDifferences) {
  using Jet = ceres::Jet<double, 3>;
  ModuleLimits limits = limits_with_end_stops(kPi / 2);
  limits.max_steering_rate = 2.0;
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.5, 0.1, limits);
  ModuleCommandRule rule;
  rule.shape = LimitShape::kSmooth;
  const double dt = 0.5;
  // Steering errors of 0.37, 0.69, -1.0 and 1.13 rad: rates inside the limit, in its blend and
  // past it.
  Eigen::VectorXd angles(4);
  angles << 0.3, -0.2, 1.2, -1.0;
  const Eigen::Vector3d twist(0.5, 0.2, 0.4);
  Eigen::Matrix<Jet, 3, 1> twist_jet;
  for (int j = 0; j < 3; ++j) twist_jet[j] = Jet(twist[j], j);
  const Eigen::Matrix<Jet, Eigen::Dynamic, 1> angles_jet = angles.cast<Jet>();
  Eigen::Matrix<Jet, Eigen::Dynamic, 1> inputs_jet(8);
  module_commands<Jet>(layout, twist_jet, angles_jet, dt, rule, inputs_jet);
  const double h = 1e-7;
  for (int j = 0; j < 3; ++j) {
    Eigen::VectorXd plus(8), minus(8);
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    step[j] = h;
    module_commands<double>(layout, twist + step, angles, dt, rule, plus);
    module_commands<double>(layout, twist - step, angles, dt, rule, minus);
    for (int r = 0; r < 8; ++r) {
      const double difference = (plus[r] - minus[r]) / (2 * h);
      EXPECT_NEAR(inputs_jet[r].v[j], difference, 1e-5 * (1.0 + std::abs(difference))) << "input " << r << ", twist " << j;
    }
  }
}

}  // namespace
}  // namespace swerve
