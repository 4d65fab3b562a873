// LatencyCompensator: a fresh measurement passes bit for bit; a delayed one is rolled forward by the
// commands sent since it was taken, checked against hand-integrated motions (straight drive, spin
// in place, a steering turn), and never by more commands than were recorded.
#include "swerve/mpc/latency_compensator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "swerve/config/config_error.hpp"

namespace swerve {
namespace {

constexpr double kDt = 0.05;
constexpr double kRadius = 0.1;

ModuleLayout square_robot() { return ModuleLayout::rectangle(0.6, 0.6, kRadius); }

// Every module at `angle`, its wheel at `surface_speed` (m/s), its steering at `rate`.
ModuleArray<ModuleCommand> uniform_commands(double angle, double surface_speed, double rate) {
  ModuleArray<ModuleCommand> commands(4);
  for (ModuleCommand& c : commands) {
    c.steering_angle = angle;
    c.steering_rate = rate;
    c.wheel_speed = surface_speed / kRadius;
  }
  return commands;
}

Eigen::VectorXd state(double x, double y, double psi, double angle) {
  Eigen::VectorXd s = Eigen::VectorXd::Zero(10);
  s << x, y, psi, 0.0, 0.0, 0.0, angle, angle, angle, angle;
  return s;
}

TEST(LatencyCompensator, AFreshMeasurementPassesBitForBit) {
  LatencyCompensator compensator(square_robot(), kDt);
  compensator.record(uniform_commands(0.3, 1.0, 2.0));
  Eigen::VectorXd measured = state(1.0, 2.0, 0.5, 0.3);
  measured.segment<3>(3) << 0.1, 0.2, 0.3;
  Eigen::VectorXd now(10);
  EXPECT_EQ(compensator.compensate(measured, 0.0, now), 0);
  EXPECT_EQ(now, measured);
  // Less than half a period of latency rounds to none.
  EXPECT_EQ(compensator.compensate(measured, 0.4 * kDt, now), 0);
  EXPECT_EQ(now, measured);
}

TEST(LatencyCompensator, StraightDriveMovesThePoseAlongTheWheelsInTheWorldFrame) {
  LatencyCompensator compensator(square_robot(), kDt);
  // Two periods of 1 m/s along the body y axis (modules at +90 deg), the body turned by 90 deg:
  // the vehicle moves along world -x.
  compensator.record(uniform_commands(kPi / 2, 1.0, 0.0));
  compensator.record(uniform_commands(kPi / 2, 1.0, 0.0));
  const Eigen::VectorXd measured = state(0.0, 0.0, kPi / 2, kPi / 2);
  Eigen::VectorXd now(10);
  EXPECT_EQ(compensator.compensate(measured, 2 * kDt, now), 2);
  EXPECT_NEAR(now[0], -2 * kDt * 1.0, 1e-12);
  EXPECT_NEAR(now[1], 0.0, 1e-12);
  EXPECT_NEAR(now[2], kPi / 2, 1e-12);
  EXPECT_NEAR(now[3], 0.0, 1e-12);  // the twist the drives are told now, in the body frame
  EXPECT_NEAR(now[4], 1.0, 1e-12);
  EXPECT_NEAR(now[5], 0.0, 1e-12);
}

TEST(LatencyCompensator, SteeringAnglesAdvanceByTheCommandedRatesOfTheLatencyOnly) {
  LatencyCompensator compensator(square_robot(), kDt);
  compensator.record(uniform_commands(0.0, 0.0, 9.0));  // older than the measurement: not applied
  compensator.record(uniform_commands(0.0, 0.0, 1.0));
  compensator.record(uniform_commands(0.0, 0.0, -3.0));
  Eigen::VectorXd now(10);
  EXPECT_EQ(compensator.compensate(state(0, 0, 0, 0.2), 2 * kDt, now), 2);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(now[6 + i], 0.2 + kDt * (1.0 - 3.0), 1e-12);
  // The angle stays in (-pi, pi] across the seam.
  compensator.reset();
  compensator.record(uniform_commands(0.0, 0.0, 2.0));
  EXPECT_EQ(compensator.compensate(state(0, 0, 0, kPi - 0.05), kDt, now), 1);
  EXPECT_NEAR(now[6], -kPi + 0.05, 1e-12);
}

TEST(LatencyCompensator, SpinInPlaceTurnsTheHeadingOnly) {
  LatencyCompensator compensator(square_robot(), kDt);
  // Modules tangent to the circle through them (radius 0.3 sqrt 2): yaw rate = speed / radius.
  const double radius = 0.3 * std::sqrt(2.0);
  ModuleArray<ModuleCommand> commands(4);
  const ModuleLayout layout = square_robot();
  Eigen::VectorXd measured = state(1.0, 1.0, 0.0, 0.0);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d p = layout.positions_body()[static_cast<std::size_t>(i)];
    commands[i].steering_angle = measured[6 + i] = std::atan2(p.x(), -p.y());
    commands[i].wheel_speed = 0.5 / kRadius;
  }
  compensator.record(commands);
  Eigen::VectorXd now(10);
  EXPECT_EQ(compensator.compensate(measured, kDt, now), 1);
  EXPECT_NEAR(now[0], 1.0, 1e-12);
  EXPECT_NEAR(now[1], 1.0, 1e-12);
  EXPECT_NEAR(now[2], kDt * 0.5 / radius, 1e-12);
  EXPECT_NEAR(now[5], 0.5 / radius, 1e-12);
}

TEST(LatencyCompensator, NeverRollsForwardByMoreCommandsThanWereRecordedOrKept) {
  LatencyCompensator compensator(square_robot(), kDt);
  Eigen::VectorXd now(10);
  const Eigen::VectorXd measured = state(0, 0, 0, 0);
  EXPECT_EQ(compensator.compensate(measured, 5 * kDt, now), 0);  // nothing recorded yet
  EXPECT_EQ(now, measured);
  for (int k = 0; k < 20; ++k) compensator.record(uniform_commands(0.0, 0.0, 0.1));
  EXPECT_EQ(compensator.compensate(measured, 100 * kDt, now), LatencyCompensator::kMaxSteps);
  EXPECT_NEAR(now[6], LatencyCompensator::kMaxSteps * kDt * 0.1, 1e-12);
  EXPECT_EQ(compensator.compensate(measured, 1e300, now), LatencyCompensator::kMaxSteps);
  // A non-finite latency or a wrong-size state is no latency: the measurement passes unchanged.
  EXPECT_EQ(compensator.compensate(measured, std::nan(""), now), 0);
  EXPECT_EQ(now, measured);
}

TEST(LatencyCompensator, RejectsANonPositivePeriodNamingIt) {
  EXPECT_THROW(LatencyCompensator(square_robot(), 0.0), ConfigError);
  try {
    LatencyCompensator(square_robot(), -1.0);
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dt"), std::string::npos);
  }
}

}  // namespace
}  // namespace swerve
