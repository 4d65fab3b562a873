// The stuck-steering detector (control/steering_fault_detector.hpp) against modules simulated here
// by hand: one that never moves while commanded (found after the windows the options name, by
// count), one that follows through a first-order rate lag from rest at full rate (the lag's
// worst case, never found), the same under steering-encoder noise, a module held at its end stop,
// and the option rules.
#include "swerve/control/steering_fault_detector.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kPeriod = 0.05;

ModuleLayout two_modules() { return ModuleLayout({{0.5, 0.0}, {-0.5, 0.0}}, 0.05); }

ModuleArray<ModuleCommand> commands_with_rates(double rate0, double rate1) {
  ModuleArray<ModuleCommand> commands(2);
  commands[0].steering_rate = rate0;
  commands[1].steering_rate = rate1;
  return commands;
}

// Module 0 follows its commanded rate through a first-order lag of time constant `lag` (fine
// substeps); module 1 never moves. Returns the cycle (1-based) module `which` was found at, or -1.
int cycles_to_find(int which, double rate, double lag, double noise, int cycles,
                   FaultDetectionOptions options = {}) {
  SteeringFaultDetector detector(two_modules(), kPeriod, options);
  std::mt19937 rng(7);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  double angle = 0.0, actual_rate = 0.0;
  for (int k = 0; k < cycles; ++k) {
    const double t = k * kPeriod;
    const Eigen::Vector2d measured(angle + noise * gaussian(rng), 0.3 + noise * gaussian(rng));
    if (detector.observe(measured, t) && detector.stuck(which)) return k;
    // The commands keep asking for the same rate (a module that never arrives at its target).
    detector.commanded(commands_with_rates(rate, rate), t);
    constexpr int kSubsteps = 50;
    for (int s = 0; s < kSubsteps; ++s) {
      const double h = kPeriod / kSubsteps;
      actual_rate += h * (rate - actual_rate) / lag;
      angle += h * actual_rate;
    }
  }
  return -1;
}

TEST(SteeringFaultDetector, AModuleThatNeverMovesIsFoundAfterItsWindowsConfirm) {
  // 2 rad/s asks 0.1 rad per period: each 3-period window asks 0.3 rad, over 0.2. The first window
  // is complete at the fourth measurement (k = 3), the second confirms at k = 4.
  EXPECT_EQ(cycles_to_find(1, 2.0, 0.05, 0.0, 40), 4);
  FaultDetectionOptions quicker;
  quicker.confirm_cycles = 1;
  EXPECT_EQ(cycles_to_find(1, 2.0, 0.05, 0.0, 40, quicker), 3);
}

TEST(SteeringFaultDetector, AModuleFollowingThroughItsLagFromRestAtFullRateIsNeverFound) {
  for (const double lag : {0.02, 0.05}) {
    EXPECT_EQ(cycles_to_find(0, 3.0, lag, 0.0, 40), -1) << "lag " << lag;
  }
}

TEST(SteeringFaultDetector, EncoderNoiseOfTwoHundredthsOfARadianRaisesNoAlarmOnAFollowingModule) {
  // A slow turn that keeps every window just over the threshold (1.5 rad/s: 0.225 rad per window)
  // is the hardest case for a following module under noise; 2000 cycles of it.
  EXPECT_EQ(cycles_to_find(0, 1.5, 0.05, 0.02, 2000), -1);
  // The stuck one is still found under the same noise.
  EXPECT_GT(cycles_to_find(1, 2.0, 0.05, 0.02, 40), 0);
}

TEST(SteeringFaultDetector, AModuleHeldAtItsEndStopIsNotStuck) {
  ModuleLimits limits;
  limits.min_steering_angle = -0.3;
  limits.max_steering_angle = 0.3;
  const ModuleLayout layout({{0.5, 0.0}, {-0.5, 0.0}}, 0.05, limits);
  SteeringFaultDetector detector(layout, kPeriod, {});
  for (int k = 0; k < 20; ++k) {
    // Both at the +0.3 rad stop, commanded further into it: the stop, not a fault, holds them.
    EXPECT_FALSE(detector.observe(Eigen::Vector2d(0.3, 0.3), k * kPeriod)) << "cycle " << k;
    detector.commanded(commands_with_rates(2.0, 2.0), k * kPeriod);
  }
}

TEST(SteeringFaultDetector, ARepeatedMeasurementAddsNoWindowAndForgetClearsAVerdict) {
  SteeringFaultDetector detector(two_modules(), kPeriod, {});
  for (int k = 0; k < 10; ++k) {
    detector.observe(Eigen::Vector2d(0.0, 0.0), k * kPeriod);
    detector.commanded(commands_with_rates(2.0, 0.0), k * kPeriod);
  }
  ASSERT_TRUE(detector.stuck(0));
  EXPECT_FALSE(detector.stuck(1));
  detector.forget(0);
  EXPECT_FALSE(detector.stuck(0));
  // The same stamp again (a frozen sensor) is no new window.
  EXPECT_FALSE(detector.observe(Eigen::Vector2d(0.0, 0.0), 9 * kPeriod));
  EXPECT_FALSE(detector.stuck(0));
}

TEST(SteeringFaultDetector, NonFiniteInputIsIgnored) {
  SteeringFaultDetector detector(two_modules(), kPeriod, {});
  EXPECT_FALSE(detector.observe(Eigen::Vector2d(std::nan(""), 0.0), 0.0));
  EXPECT_FALSE(detector.observe(Eigen::Vector2d(0.0, 0.0), std::nan("")));
  EXPECT_FALSE(detector.observe(Eigen::Vector3d(0.0, 0.0, 0.0), 0.0));  // wrong size
}

TEST(FaultDetectionOptions, EachFieldOutOfRangeIsRefusedNamingIt) {
  const auto refused = [](const FaultDetectionOptions& options, const char* field) {
    try {
      options.validate();
      ADD_FAILURE() << field << ": expected ConfigError";
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(field), std::string::npos) << error.what();
    }
  };
  FaultDetectionOptions o;
  o.min_commanded_turn = 0.0;
  refused(o, "min_commanded_turn");
  o = {};
  o.max_followed_share = 1.0;
  refused(o, "max_followed_share");
  o = {};
  o.window_cycles = 0;
  refused(o, "window_cycles");
  o = {};
  o.confirm_cycles = 61;
  refused(o, "confirm_cycles");
  EXPECT_THROW(SteeringFaultDetector(two_modules(), 0.0, {}), ConfigError);
}

}  // namespace
}  // namespace swerve
