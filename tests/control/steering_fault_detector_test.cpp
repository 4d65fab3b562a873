// The stuck-steering detector (control/steering_fault_detector.hpp) against modules simulated here
// by hand: one that never moves while commanded (found after the windows the options name, by
// count), one that follows through a first-order rate lag from rest at full rate (the lag's
// worst case, never found), the same under steering-encoder noise and on a slow-steering carrier
// at 20 and 100 Hz, a module held at its end stop, and the option rules.
#include "swerve/control/steering_fault_detector.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "support/config_errors.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kPeriod = 0.05;

// Two modules steering at up to `max_rate` rad/s (the agv_4wheel's 3 rad/s by default).
ModuleLayout two_modules(double max_rate = 3.0) {
  ModuleLimits limits;
  limits.max_steering_rate = max_rate;
  return ModuleLayout({{0.5, 0.0}, {-0.5, 0.0}}, 0.05, limits);
}

ModuleArray<ModuleCommand> commands_with_rates(double rate0, double rate1) {
  ModuleArray<ModuleCommand> commands(2);
  commands[0].steering_rate = rate0;
  commands[1].steering_rate = rate1;
  return commands;
}

// A vehicle and a loop for the detector: module 0 follows its commanded rate through a first-order
// lag of time constant `lag` (fine substeps); module 1 never moves.
struct Loop {
  double max_rate = 3.0;  // rad/s, the steering-rate limit
  double lag = 0.05;      // s, the steering lag (the detector is told it)
  double period = kPeriod;
  double noise = 0.0;  // rad, encoder noise on both
  FaultDetectionOptions options;
};

// The cycle (0-based) module `which` was found at, or -1, commanding `rate` for `cycles` cycles.
int cycles_to_find(int which, double rate, int cycles, const Loop& loop = {}) {
  SteeringFaultDetector detector(two_modules(loop.max_rate), loop.period, loop.lag, loop.options);
  std::mt19937 rng(7);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  double angle = 0.0, actual_rate = 0.0;
  for (int k = 0; k < cycles; ++k) {
    const double t = k * loop.period;
    const Eigen::Vector2d measured(angle + loop.noise * gaussian(rng), 0.3 + loop.noise * gaussian(rng));
    if (detector.observe(measured, t) && detector.stuck(which)) return k;
    // The commands keep asking for the same rate (a module that never arrives at its target).
    detector.commanded(commands_with_rates(rate, rate), t);
    constexpr int kSubsteps = 50;
    for (int s = 0; s < kSubsteps; ++s) {
      const double h = loop.period / kSubsteps;
      actual_rate += loop.lag > 0.0 ? h * (rate - actual_rate) / loop.lag : rate - actual_rate;
      angle += h * actual_rate;
    }
  }
  return -1;
}

TEST(SteeringFaultDetector, AModuleThatNeverMovesIsFoundAfterItsWindowsConfirm) {
  // 2 rad/s asks 0.1 rad per period: each 3-period window asks 0.3 rad, over 0.2. The first window
  // is complete at the fourth measurement (k = 3), the second confirms at k = 4.
  EXPECT_EQ(cycles_to_find(1, 2.0, 40), 4);
  Loop quicker;
  quicker.options.confirm_cycles = 1;
  EXPECT_EQ(cycles_to_find(1, 2.0, 40, quicker), 3);
}

TEST(SteeringFaultDetector, AModuleFollowingThroughItsLagFromRestAtFullRateIsNeverFound) {
  for (const double lag : {0.0, 0.02, 0.05, 0.08}) {
    Loop loop;
    loop.lag = lag;
    EXPECT_EQ(cycles_to_find(0, 3.0, 40, loop), -1) << "lag " << lag;
  }
}

TEST(SteeringFaultDetector, EncoderNoiseOfTwoHundredthsOfARadianRaisesNoAlarmOnAFollowingModule) {
  // A slow turn that keeps every window just over the threshold (1.5 rad/s: 0.225 rad per window)
  // is the hardest case for a following module under noise; 2000 cycles of it.
  Loop noisy;
  noisy.noise = 0.02;
  EXPECT_EQ(cycles_to_find(0, 1.5, 2000, noisy), -1);
  // The stuck one is still found under the same noise.
  EXPECT_GT(cycles_to_find(1, 2.0, 40, noisy), 0);
}

TEST(SteeringFaultDetector, OnASlowSteeringCarrierTheWindowGrowsUntilItCanAskTheTurn) {
  // 1 rad/s and an 80 ms lag (carrier_8module) at 20 Hz: 3 periods could ask 0.15 rad at most, the
  // least judged, and only at full rate. The window grows to 6 periods (2 x 0.15 rad at 1 rad/s);
  // at 100 Hz to 30 (0.3 rad at 1 rad/s takes 0.3 s). The lag lengthens no window: the commands
  // are run through it.
  Loop carrier;
  carrier.max_rate = 1.0;
  carrier.lag = 0.08;
  EXPECT_EQ(SteeringFaultDetector(two_modules(1.0), kPeriod, 0.08, {}).window_periods(), 6);
  EXPECT_EQ(SteeringFaultDetector(two_modules(1.0), 0.01, 0.08, {}).window_periods(), 30);
  EXPECT_EQ(SteeringFaultDetector(two_modules(3.0), kPeriod, 0.03, {}).window_periods(), 3);  // agv_4wheel
  // Found after 6 + 1 periods at full rate, and a following module is never found, at 20 and 100 Hz.
  EXPECT_EQ(cycles_to_find(1, 1.0, 60, carrier), 7);
  EXPECT_EQ(cycles_to_find(0, 1.0, 200, carrier), -1);
  carrier.period = 0.01;
  EXPECT_EQ(cycles_to_find(1, 1.0, 100, carrier), 31);
  EXPECT_EQ(cycles_to_find(0, 1.0, 400, carrier), -1);
}

// A healthy steering behind a 92 ms lag whose commands swing between its rate limits every 8
// periods (a 127 kg, 8-module carrier of the envelope, 17 ms period): over a window the bare sum of
// the commands asks up to 0.7 rad more than the lag lets any module turn. Judged on that sum, every
// module of such a vehicle was found stuck; run through the lag, none is, and a stuck one still is.
TEST(SteeringFaultDetector, AHealthySteeringWhoseCommandsSwingBetweenItsRateLimitsIsNeverFound) {
  constexpr double period = 0.017, lag = 0.092, limit = 3.7;
  SteeringFaultDetector detector(two_modules(limit), period, lag, {});
  double angle = 0.0, actual_rate = 0.0;
  int found_at = -1;
  for (int k = 0; k < 600; ++k) {
    const double t = k * period;
    if (detector.observe(Eigen::Vector2d(angle, 0.3), t) && found_at < 0) found_at = k;
    const double rate = (k / 8) % 2 == 0 ? limit : -limit;
    detector.commanded(commands_with_rates(rate, rate), t);  // module 1 never moves: stuck
    constexpr int kSubsteps = 50;
    for (int s = 0; s < kSubsteps; ++s) {
      const double h = period / kSubsteps;
      actual_rate += h * (rate - actual_rate) / lag;
      angle += h * actual_rate;
    }
  }
  EXPECT_GT(found_at, 0);
  EXPECT_FALSE(detector.stuck(0));
  EXPECT_TRUE(detector.stuck(1));
}

TEST(SteeringFaultDetector, AModuleHeldAtItsEndStopIsNotStuck) {
  ModuleLimits limits;
  limits.min_steering_angle = -0.3;
  limits.max_steering_angle = 0.3;
  const ModuleLayout layout({{0.5, 0.0}, {-0.5, 0.0}}, 0.05, limits);
  SteeringFaultDetector detector(layout, kPeriod, 0.05, {});
  for (int k = 0; k < 20; ++k) {
    // Both at the +0.3 rad stop, commanded further into it: the stop, not a fault, holds them.
    EXPECT_FALSE(detector.observe(Eigen::Vector2d(0.3, 0.3), k * kPeriod)) << "cycle " << k;
    detector.commanded(commands_with_rates(2.0, 2.0), k * kPeriod);
  }
}

TEST(SteeringFaultDetector, ARepeatedMeasurementAddsNoWindowAndForgetClearsAVerdict) {
  SteeringFaultDetector detector(two_modules(), kPeriod, 0.05, {});
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
  SteeringFaultDetector detector(two_modules(), kPeriod, 0.05, {});
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
  EXPECT_THROW(SteeringFaultDetector(two_modules(), 0.0, 0.05, {}), ConfigError);
  EXPECT_THROW(SteeringFaultDetector(two_modules(), kPeriod, -0.01, {}), ConfigError);
  // A window longer than the history: 3 rad asked of a 1 rad/s steering at 100 Hz (600 periods).
  FaultDetectionOptions far;
  far.min_commanded_turn = 3.0;
  EXPECT_NE(testing::config_error_of([&] { SteeringFaultDetector(two_modules(1.0), 0.01, 0.05, far); }).find("window"),
            std::string::npos);
  // A lag of seconds no longer lengthens the window: the commands are run through it.
  EXPECT_EQ(SteeringFaultDetector(two_modules(), 0.01, 2.0, {}).window_periods(), 10);  // 2 x 0.15 rad at 3 rad / s
}

}  // namespace
}  // namespace swerve
