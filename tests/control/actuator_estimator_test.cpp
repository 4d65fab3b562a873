// ActuatorEstimator: the commands sent, followed through first-order lags; rolling with the body
// when there is none to follow.
#include <gtest/gtest.h>

#include <cmath>

#include "support/model_fixtures.hpp"
#include "swerve/control/actuator_estimator.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {
namespace {

constexpr double kMaxGap = 0.2;

VehicleParams unclamped_vehicle() {
  VehicleParams vehicle = testing::make_params(4);
  vehicle.plant.actuator_saturation = false;  // the pure first-order lag, for the exact answer
  vehicle.actuators.drive_time_constant = 0.05;
  vehicle.actuators.steering_time_constant = 0.1;
  return vehicle;
}

// Driving straight ahead at 1 m/s, every module at 0 rad.
Eigen::VectorXd straight_at_one_metre_per_second() {
  Eigen::VectorXd state = Eigen::VectorXd::Zero(10);
  state[StateIndex::kVx] = 1.0;
  return state;
}

ModuleArray<ModuleCommand> commands(double wheel_speed, double steering_rate) {
  ModuleArray<ModuleCommand> sent(4);
  for (int i = 0; i < 4; ++i) {
    sent[i].wheel_speed = wheel_speed;
    sent[i].steering_rate = steering_rate;
  }
  return sent;
}

TEST(ActuatorEstimator, WithNoCommandToFollowTheWheelsRollWithTheBodyAndTheSteeringRests) {
  const VehicleParams vehicle = unclamped_vehicle();
  ActuatorEstimator estimator(vehicle, true, true);
  ASSERT_TRUE(estimator.active());
  estimator.begin_step();
  estimator.estimate(straight_at_one_metre_per_second(), 0.0, kMaxGap);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(estimator.wheel_speeds()[i], 1.0 / vehicle.layout.wheel_radius(), 1e-12);
    EXPECT_EQ(estimator.steering_rates()[i], 0.0);
  }
}

TEST(ActuatorEstimator, FollowsTheSentCommandsThroughTheFirstOrderLags) {
  const VehicleParams vehicle = unclamped_vehicle();
  ActuatorEstimator estimator(vehicle, true, true);
  const double rolling = 1.0 / vehicle.layout.wheel_radius();
  estimator.begin_step();
  estimator.estimate(straight_at_one_metre_per_second(), 1.0, kMaxGap);
  estimator.record_sent(commands(rolling + 4.0, 0.5));
  estimator.begin_step();
  estimator.estimate(straight_at_one_metre_per_second(), 1.05, kMaxGap);
  // x(h) = c + (x0 - c) exp(-h / tau)
  const double wheel = rolling + 4.0 - 4.0 * std::exp(-0.05 / 0.05);
  const double steering = 0.5 - 0.5 * std::exp(-0.05 / 0.1);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(estimator.wheel_speeds()[i], wheel, 1e-9);
    EXPECT_NEAR(estimator.steering_rates()[i], steering, 1e-9);
  }
}

TEST(ActuatorEstimator, RestartsFromRollingAfterAGapLongerThanAllowedOrAForget) {
  const VehicleParams vehicle = unclamped_vehicle();
  const double rolling = 1.0 / vehicle.layout.wheel_radius();
  for (const bool forget : {false, true}) {
    ActuatorEstimator estimator(vehicle, true, true);
    estimator.begin_step();
    estimator.estimate(straight_at_one_metre_per_second(), 1.0, kMaxGap);
    estimator.record_sent(commands(rolling + 4.0, 0.5));
    if (forget) estimator.forget();
    estimator.begin_step();
    estimator.estimate(straight_at_one_metre_per_second(), forget ? 1.05 : 1.0 + 2.0 * kMaxGap, kMaxGap);
    EXPECT_NEAR(estimator.wheel_speeds()[0], rolling, 1e-12) << (forget ? "after forget()" : "after a gap");
    EXPECT_EQ(estimator.steering_rates()[0], 0.0);
  }
}

TEST(ActuatorEstimator, DoesNotFollowCommandsOfAStepThatDidNotEstimate) {
  // A step that sent without estimating (a fallback before the problem was set up) breaks the chain.
  const VehicleParams vehicle = unclamped_vehicle();
  ActuatorEstimator estimator(vehicle, true, false);
  estimator.begin_step();
  estimator.record_sent(commands(50.0, 0.0));
  estimator.begin_step();
  estimator.estimate(straight_at_one_metre_per_second(), 0.05, kMaxGap);
  EXPECT_NEAR(estimator.wheel_speeds()[0], 1.0 / vehicle.layout.wheel_radius(), 1e-12);
  EXPECT_EQ(estimator.steering_rates().size(), 0);
}

TEST(ActuatorEstimator, WithoutLaggedActuatorsInThePredictionItEstimatesNothing) {
  ActuatorEstimator estimator(unclamped_vehicle(), false, false);
  EXPECT_FALSE(estimator.active());
  EXPECT_EQ(estimator.wheel_speeds().size(), 0);
}

}  // namespace
}  // namespace swerve
