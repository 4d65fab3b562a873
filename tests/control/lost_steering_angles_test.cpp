// The stand-in for a lost steering angle: the last reading turned on by the rates sent since,
// worked by hand, within the end stops, across a measurement delay, and what it will not stand in
// for.
#include "swerve/control/lost_steering_angles.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "support/config_errors.hpp"

namespace swerve {
namespace {

constexpr double kPeriod = 0.05;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

ModuleLayout layout_with_end_stops() {
  ModuleLimits limits;
  limits.min_steering_angle = -1.0;
  limits.max_steering_angle = 1.0;
  return ModuleLayout::rectangle(0.8, 0.6, 0.1, limits);
}

ModuleArray<ModuleCommand> rates(double module_1_rate) {
  ModuleArray<ModuleCommand> commands(4);
  commands[1].steering_rate = module_1_rate;
  return commands;
}

Eigen::VectorXd measurement(double module_1_angle) {
  Eigen::VectorXd measured = Eigen::VectorXd::Zero(10);
  measured[3] = 1.0;
  for (int i = 0; i < 4; ++i) measured[6 + i] = 0.1 * i;
  measured[7] = module_1_angle;
  return measured;
}

TEST(LostSteeringAngles, ALostAngleIsItsLastReadingTurnedOnByTheRatesSentSince) {
  LostSteeringAngles angles(layout_with_end_stops(), kPeriod);
  EXPECT_FALSE(angles.repair(measurement(0.3), 0.0));  // all read: nothing to stand in for
  angles.commanded(rates(0.4), 0.0);
  ASSERT_TRUE(angles.repair(measurement(kNaN), 0.05));
  EXPECT_TRUE(angles.lost(1));
  EXPECT_FALSE(angles.lost(0));
  EXPECT_DOUBLE_EQ(angles.repaired()[7], 0.3 + 0.4 * 0.05);
  EXPECT_DOUBLE_EQ(angles.repaired()[6], 0.0);  // the others as measured
  EXPECT_DOUBLE_EQ(angles.repaired()[3], 1.0);
  // Two more periods at other rates: 0.32 + 0.05 (-0.2) + 0.05 (0.6).
  angles.commanded(rates(-0.2), 0.05);
  ASSERT_TRUE(angles.repair(measurement(kNaN), 0.10));
  angles.commanded(rates(0.6), 0.10);
  ASSERT_TRUE(angles.repair(measurement(kNaN), 0.15));
  EXPECT_NEAR(angles.repaired()[7], 0.32 - 0.01 + 0.03, 1e-15);
  // A reading again is taken as it is.
  EXPECT_FALSE(angles.repair(measurement(0.5), 0.20));
  EXPECT_FALSE(angles.lost(1));
}

TEST(LostSteeringAngles, ADelayedMeasurementIntegratesTheRatesOverItsOwnInterval) {
  // Measurements one period old: the one stamped 0.05 ends the interval [0, 0.05], over which the
  // rate sent at 0 acted, not the rate sent at 0.05.
  LostSteeringAngles angles(layout_with_end_stops(), kPeriod);
  angles.repair(measurement(0.0), 0.0);
  angles.commanded(rates(1.0), 0.0);
  angles.commanded(rates(-1.0), 0.05);
  ASSERT_TRUE(angles.repair(measurement(kNaN), 0.05));
  EXPECT_DOUBLE_EQ(angles.repaired()[7], 0.05);
}

TEST(LostSteeringAngles, TheStandInStopsAtTheEndStops) {
  LostSteeringAngles angles(layout_with_end_stops(), kPeriod);
  angles.repair(measurement(0.98), 0.0);
  angles.commanded(rates(1.0), 0.0);
  ASSERT_TRUE(angles.repair(measurement(kNaN), 0.05));
  EXPECT_DOUBLE_EQ(angles.repaired()[7], 1.0);
}

TEST(LostSteeringAngles, NothingIsStoodInForWithoutAReadingABadPoseOrTimeGoingBack) {
  LostSteeringAngles angles(layout_with_end_stops(), kPeriod);
  EXPECT_FALSE(angles.repair(measurement(kNaN), 0.0));  // never read
  EXPECT_FALSE(angles.lost(1));
  angles.repair(measurement(0.3), 0.1);
  Eigen::VectorXd bad_pose = measurement(kNaN);
  bad_pose[0] = kNaN;
  EXPECT_FALSE(angles.repair(bad_pose, 0.15));
  EXPECT_FALSE(angles.repair(measurement(kNaN), 0.05));  // older than the last reading
  EXPECT_FALSE(angles.repair(Eigen::VectorXd::Zero(7), 0.2));  // wrong size
  angles.reset();
  EXPECT_FALSE(angles.repair(measurement(kNaN), 0.2));  // a new run has read nothing
  EXPECT_NE(testing::config_error_of([] { LostSteeringAngles(layout_with_end_stops(), 0.0); }).find("control_period = 0"),
            std::string::npos);
}

}  // namespace
}  // namespace swerve
