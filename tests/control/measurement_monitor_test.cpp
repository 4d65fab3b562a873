// MeasurementMonitor: the age limit (its default from the control period, its tolerance against
// the round-off of timestamps), and when a repeated measurement counts as frozen.
#include "swerve/control/measurement_monitor.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "swerve/control/latency_compensator.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kNever = std::numeric_limits<double>::infinity();  // no motion commanded

// Pose, twist and four steering angles; `vx` forward.
Eigen::VectorXd measurement(double x, double vx = 0.0) {
  Eigen::VectorXd m = Eigen::VectorXd::Zero(10);
  m[0] = x;
  m[3] = vx;
  return m;
}

std::string text(const char* reason) { return reason != nullptr ? reason : "(fresh)"; }

TEST(MeasurementMonitor, TheDefaultAgeLimitIsWhatTheLatencyCompensationRollsForward) {
  EXPECT_DOUBLE_EQ(StalenessOptions{}.max_age_at(0.05), LatencyCompensator::kMaxSteps * 0.05);
  StalenessOptions set;
  set.max_age = 0.3;
  EXPECT_DOUBLE_EQ(set.max_age_at(0.05), 0.3);
  // 50 Hz: 150 ms of latency is inside the default limit, 170 ms is not.
  MeasurementMonitor monitor(10, StalenessOptions{}, 0.02);
  EXPECT_DOUBLE_EQ(monitor.max_age(), 0.16);
  EXPECT_EQ(monitor.check(measurement(0.0), 1.0, 1.0 - 0.15, kNever), nullptr);
  EXPECT_EQ(text(monitor.check(measurement(0.1), 1.02, 1.02 - 0.17, kNever)),
            "measurement stale: older than stale_measurement.max_age");
}

TEST(MeasurementMonitor, AMeasurementExactlyAtTheAgeLimitIsFreshWhateverTheRoundOff) {
  // 20 Hz, max_age two periods, every measurement two periods late: t - (t - 0.1) rounds to a few
  // ulps either side of 0.1 depending on t. Without the tolerance about a third of these were stale.
  StalenessOptions options;
  options.max_age = 0.1;
  MeasurementMonitor monitor(10, options, 0.05);
  int rounded_over = 0;
  for (int k = 2; k < 2000; ++k) {
    const double t = k * 0.05;
    const double measured_at = t - 0.1;
    if (t - measured_at > 0.1) ++rounded_over;
    EXPECT_EQ(monitor.check(measurement(0.5 * measured_at, 0.5), t, measured_at, kNever), nullptr) << "t = " << t;
  }
  EXPECT_GT(rounded_over, 0) << "the case this guards against never arose";
  EXPECT_NE(monitor.check(measurement(0.0), 200.0, 200.0 - 0.1 - 1e-5, kNever), nullptr);
}

TEST(MeasurementMonitor, AVehicleStandingStillIsNotFrozenUntilItHadBeenToldToMoveForAPeriod) {
  // Noiseless and standing: the same measurement every cycle, 100 ms late at 20 Hz. Motion is
  // commanded from t = 1.0 on; the measurements taken before 1.05 cannot show it yet.
  MeasurementMonitor monitor(10, StalenessOptions{}, 0.05);
  for (int k = 0; k <= 22; ++k) {
    const double t = k * 0.05;
    const double since = t > 1.0 ? 1.0 : kNever;
    EXPECT_EQ(monitor.check(measurement(0.0), t, t - 0.1, since), nullptr) << "t = " << t;
  }
  // Measurements taken at 1.05 and 1.10 (at t = 1.15 and 1.20) would show a move that began at 1.0:
  // with three identical ones in a row, the sensor is frozen.
  EXPECT_EQ(monitor.check(measurement(0.0), 1.15, 1.05, 1.0), nullptr);
  EXPECT_EQ(text(monitor.check(measurement(0.0), 1.20, 1.10, 1.0)),
            "measurement stale: identical for stale_measurement.frozen_cycles cycles while moving");
}

TEST(MeasurementMonitor, AResentMeasurementWithItsOldTimestampIsJudgedByItsAgeNotAsFrozen) {
  MeasurementMonitor monitor(10, StalenessOptions{}, 0.05);
  const Eigen::VectorXd cruising = measurement(1.0, 0.5);
  for (int k = 0; k < 8; ++k) {
    const double t = 2.0 + 0.05 * k;
    EXPECT_EQ(monitor.check(cruising, t, 2.0, 0.0), nullptr) << "t = " << t;
  }
  EXPECT_NE(monitor.check(cruising, 2.45, 2.0, 0.0), nullptr);  // now older than 8 periods
}

TEST(MeasurementMonitor, ARepeatUnderNewTimestampsWhileMovingIsFrozenAtTheThirdIdentical) {
  MeasurementMonitor monitor(10, StalenessOptions{}, 0.05);
  const Eigen::VectorXd cruising = measurement(1.0, 0.5);
  EXPECT_EQ(monitor.check(cruising, 1.0, 1.0, kNever), nullptr);
  EXPECT_EQ(monitor.check(cruising, 1.05, 1.05, kNever), nullptr);
  EXPECT_NE(monitor.check(cruising, 1.10, 1.10, kNever), nullptr);
  // A fresh one clears it at once.
  EXPECT_EQ(monitor.check(measurement(1.1, 0.5), 1.15, 1.15, kNever), nullptr);
}

TEST(MeasurementMonitor, RejectsANegativeMaxAgeOrABadPeriodNamingTheField) {
  StalenessOptions options;
  options.max_age = -0.1;
  try {
    MeasurementMonitor monitor(10, options, 0.05);
    FAIL() << "accepted a negative max_age";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("StalenessOptions.max_age = -0.1"), std::string::npos) << e.what();
  }
  try {
    MeasurementMonitor monitor(10, StalenessOptions{}, 0.0);
    FAIL() << "accepted a zero period";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("MeasurementMonitor.period = 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace swerve
