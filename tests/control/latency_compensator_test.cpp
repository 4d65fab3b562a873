// LatencyCompensator: a fresh measurement passes bit for bit; a delayed one is rolled forward by the
// commands sent since it was taken, checked against hand-integrated motions (straight drive, spin
// in place, a steering turn), and never by more commands than were recorded. Its observer: off at
// gains of 1; on white noise, the analytic variance of a first-order filter; on delayed
// measurements of a commanded motion, no lag; jumps and repeated measurements.
#include "swerve/control/latency_compensator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "swerve/core/config_error.hpp"

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

// An observer on the square robot with these gains.
LatencyCompensator observer_with(double pose_gain, double steering_gain) {
  MeasurementFilterOptions filter;
  filter.pose_gain = pose_gain;
  filter.steering_gain = steering_gain;
  return LatencyCompensator(square_robot(), kDt, filter);
}

// The wheel speed (m/s) of period k in the delayed-drive tests: it changes every period.
double drive_speed(int k) { return 0.5 + 0.3 * std::sin(0.7 * k); }

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

// A standing vehicle measured with white noise: the estimate's error is an AR(1) process
// e' = (1 - g) e + g n, whose variance is sigma^2 g / (2 - g) (with g = 1: the sensor's own).
TEST(LatencyCompensator, TheObserverShrinksWhiteNoiseToSqrtOfGainOverTwoMinusGain) {
  LatencyCompensator observer = observer_with(0.3, 0.5);
  const Eigen::VectorXd truth = state(1.0, 2.0, 0.3, 0.4);
  const double sigma = 0.01;
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, sigma);
  Eigen::VectorXd now(10);
  Eigen::Array<double, 10, 1> squared = Eigen::Array<double, 10, 1>::Zero();
  const int periods = 40000, warm_up = 100;
  for (int k = 0; k < periods; ++k) {
    Eigen::VectorXd measured = truth;
    for (const int i : {0, 1, 2, 6, 7, 8, 9}) measured[i] += noise(random);
    observer.estimate(measured, k * kDt, k * kDt, now);
    observer.record(uniform_commands(0.4, 0.0, 0.0));  // standing still
    if (k >= warm_up) squared += (now - truth).array().square();
  }
  const auto rms = [&](int i) { return std::sqrt(squared[i] / (periods - warm_up)); };
  const double pose_expected = sigma * std::sqrt(0.3 / 1.7);      // 0.42 sigma
  const double steering_expected = sigma * std::sqrt(0.5 / 1.5);  // 0.58 sigma
  for (const int i : {0, 1, 2}) EXPECT_NEAR(rms(i), pose_expected, 0.05 * pose_expected) << "state " << i;
  for (const int i : {6, 7, 8, 9}) EXPECT_NEAR(rms(i), steering_expected, 0.05 * steering_expected) << "state " << i;
}

// Measurements one period late of a motion the commands explain exactly (a straight drive along
// world -x at a speed that changes every period; then a steering sweep at changing rates): the
// observer predicts with the command that acted between two measurements, so it tracks without
// lag. Using a neighbouring period's command would leave an error of the order of a speed change
// times dt.
TEST(LatencyCompensator, TheObserverTracksDelayedMeasurementsOfACommandedMotionWithoutLag) {
  LatencyCompensator observer = observer_with(0.2, 0.2);
  const auto rate = [](int k) { return 2.0 * std::cos(0.9 * k); };
  // Truth at t_k = k dt, integrated by hand. Body heading pi/2, modules at pi/2: the wheels drive
  // along body +y = world -x, and the steering angle stays at pi/2 while driving (rate 0).
  std::vector<Eigen::VectorXd> truth{state(0.0, 0.0, kPi / 2, kPi / 2)};
  const int drive = 30, sweep = 30;
  for (int k = 0; k < drive + sweep; ++k) {
    Eigen::VectorXd next = truth.back();
    if (k < drive) {
      next[0] -= kDt * drive_speed(k);
    } else {
      for (int i = 6; i < 10; ++i) next[i] = wrap_angle(next[i] + kDt * rate(k));
    }
    truth.push_back(next);
  }
  Eigen::VectorXd now(10);
  for (int k = 0; k < drive + sweep; ++k) {
    const double t = k * kDt;
    const int seen = std::max(k - 1, 0);  // one period late, except the first
    Eigen::VectorXd measured = truth[static_cast<std::size_t>(seen)];
    measured.segment<3>(3).setZero();
    observer.estimate(measured, seen * kDt, t, now);
    if (k >= 2) {
      for (const int i : {0, 1, 2, 6, 7, 8, 9}) {
        ASSERT_NEAR(now[i], truth[static_cast<std::size_t>(k)][i], 1e-9) << "period " << k << ", state " << i;
      }
    }
    observer.record(k < drive ? uniform_commands(kPi / 2, drive_speed(k), 0.0) : uniform_commands(0.0, 0.0, rate(k)));
  }
}

// The same delayed drive, long and measured with white noise: the estimate rolled forward to t is
// as close to the truth as the standing vehicle's, sigma sqrt(g / (2 - g)); an observer that
// predicted with the wrong period's command would add a lag bias on top, one that took the
// measurements as they are would keep sigma.
TEST(LatencyCompensator, TheObserverFiltersNoiseOnDelayedMeasurementsOfAMovingVehicle) {
  LatencyCompensator observer = observer_with(0.3, 0.3);
  const double sigma = 0.01;
  std::mt19937 random(11);
  std::normal_distribution<double> noise(0.0, sigma);
  const int periods = 20000, warm_up = 100;
  std::vector<double> x(periods + 1, 0.0);  // truth along world -x (heading and modules at pi/2)
  for (int k = 0; k < periods; ++k) x[static_cast<std::size_t>(k + 1)] = x[static_cast<std::size_t>(k)] - kDt * drive_speed(k);
  Eigen::VectorXd now(10);
  double squared_x = 0.0, squared_steering = 0.0;
  for (int k = 0; k < periods; ++k) {
    const int seen = std::max(k - 1, 0);
    Eigen::VectorXd measured = state(x[static_cast<std::size_t>(seen)], 0.0, kPi / 2, kPi / 2);
    measured[0] += noise(random);
    measured[6] += noise(random);
    observer.estimate(measured, seen * kDt, k * kDt, now);
    if (k >= warm_up) {
      squared_x += std::pow(now[0] - x[static_cast<std::size_t>(k)], 2);
      squared_steering += std::pow(now[6] - kPi / 2, 2);
    }
    observer.record(uniform_commands(kPi / 2, drive_speed(k), 0.0));
  }
  const double expected = sigma * std::sqrt(0.3 / 1.7);
  EXPECT_NEAR(std::sqrt(squared_x / (periods - warm_up)), expected, 0.07 * expected);
  EXPECT_NEAR(std::sqrt(squared_steering / (periods - warm_up)), expected, 0.07 * expected);
}

TEST(LatencyCompensator, AJumpBeyondTheResetBoundRestartsTheEstimateAndARepeatAddsNothing) {
  LatencyCompensator observer = observer_with(0.3, 0.3);
  Eigen::VectorXd now(10);
  int k = 0;
  const auto measure = [&](const Eigen::VectorXd& measured) {
    observer.estimate(measured, k * kDt, k * kDt, now);
    observer.record(uniform_commands(0.0, 0.0, 0.0));
    ++k;
  };
  measure(state(0.0, 0.0, 0.0, 0.0));
  EXPECT_EQ(now, state(0.0, 0.0, 0.0, 0.0));  // the first measurement is the estimate
  measure(state(0.1, 0.0, 0.0, 0.0));          // 0.1 m: noise-sized, filtered
  EXPECT_NEAR(now[0], 0.3 * 0.1, 1e-12);
  // The same measurement time again (a sensor that did not update) adds nothing.
  const Eigen::VectorXd before = now;
  observer.estimate(state(0.4, 0.0, 0.0, 0.0), (k - 1) * kDt, k * kDt, now);
  EXPECT_NEAR(now[0], before[0], 1e-12);
  // A relocalisation by 2 m, and a module turned by hand by 1 rad: taken as they are.
  measure(state(2.0, 0.0, 0.0, 0.0));
  EXPECT_EQ(now[0], 2.0);
  measure(state(2.0, 0.0, 0.0, 1.0));
  EXPECT_EQ(now[6], 1.0);
}

TEST(LatencyCompensator, RejectsObserverGainsOutsideZeroToOneNamingThem) {
  for (const double gain : {0.0, -0.5, 1.5, std::nan("")}) {
    MeasurementFilterOptions filter;
    filter.steering_gain = gain;
    try {
      LatencyCompensator(square_robot(), kDt, filter);
      ADD_FAILURE() << "accepted a steering gain of " << gain;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("MeasurementFilterOptions.steering_gain"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace swerve
