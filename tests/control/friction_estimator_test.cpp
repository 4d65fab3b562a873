// The online grip estimate: on data from the plant simulator with a known floor (a patch of known mu
// under the whole vehicle), its hold where nothing excites it, its alignment of commands with
// measurements, and its input checks.
#include "swerve/control/friction_estimator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/config_errors.hpp"
#include "support/model_fixtures.hpp"
#include "swerve/sim/simulator.hpp"

namespace swerve {
namespace {

constexpr double kPeriod = 0.05;

FrictionEstimationOptions exact_sensor_options() {
  FrictionEstimationOptions options;
  options.enabled = true;
  options.velocity_noise = 0.001;  // the simulator's sensors here are exact
  options.yaw_rate_noise = 0.001;
  return options;
}

PredictionOptions lagged_prediction() {
  PredictionOptions prediction;
  prediction.drive_lag = true;
  prediction.steering_lag = true;
  return prediction;
}

// A slalom at about 1 m/s on a floor whose grip is `mu` everywhere (the tire's own when it is
// 0.8), fed to the estimator for `seconds`: the estimate at the end.
double estimate_on_slalom(double mu, double seconds, double start_scale = 1.0) {
  const VehicleParams params = testing::make_params(4);
  SimulatorOptions options;
  options.control_period = kPeriod;
  if (mu != params.tire.mu) options.friction_patches.push_back({Eigen::Vector2d(-100.0, -100.0), Eigen::Vector2d(100.0, 100.0), mu});
  Simulator plant(params, options);
  Eigen::VectorXd start = Eigen::VectorXd::Zero(10);
  start[StateIndex::kVx] = 1.0;
  plant.reset(start);
  FrictionEstimator estimator(params, lagged_prediction(), kPeriod, exact_sensor_options());
  if (start_scale != 1.0) estimator.set_scale(start_scale);
  ModuleArray<ModuleCommand> commands(4);
  const int steps = static_cast<int>(std::lround(seconds / kPeriod));
  for (int k = 0; k < steps; ++k) {
    const double t = k * kPeriod;
    estimator.observe(plant.measurement(), t);
    for (int i = 0; i < 4; ++i) {
      // All modules swing together (a crab slalom) and the speed breathes: lateral and
      // longitudinal forces both.
      commands[i].steering_rate = 0.6 * std::cos(2.0 * t);
      commands[i].wheel_speed = (1.0 + 0.3 * std::sin(1.3 * t)) / params.layout.wheel_radius();
    }
    estimator.commanded(commands, t);
    if (!plant.advance(commands)) return std::nan("");
  }
  return estimator.scale();
}

TEST(FrictionEstimator, OnAFloorOfHalfTheTiresGripTheEstimateComesWithinThreePercentOfAHalfInFourSeconds) {
  EXPECT_NEAR(estimate_on_slalom(0.4, 4.0), 0.5, 0.015);
}

TEST(FrictionEstimator, OnTheTiresOwnFloorTheEstimateStaysWithinThreePercentOfOne) {
  EXPECT_NEAR(estimate_on_slalom(0.8, 4.0), 1.0, 0.03);
}

TEST(FrictionEstimator, AWrongStartOnADryFloorIsCorrected) {
  EXPECT_NEAR(estimate_on_slalom(0.8, 4.0, 0.4), 1.0, 0.03);
}

TEST(FrictionEstimator, CruisingStraightExcitesNothingAndTheEstimateHolds) {
  // No lateral force and a steady speed: the twist does not depend on the grip, so the estimate
  // set before must not drift on the model's small mismatches.
  const VehicleParams params = testing::make_params(4);
  Simulator plant(params, SimulatorOptions{});
  Eigen::VectorXd start = Eigen::VectorXd::Zero(10);
  start[StateIndex::kVx] = 1.0;
  plant.reset(start);
  FrictionEstimator estimator(params, lagged_prediction(), kPeriod, exact_sensor_options());
  estimator.set_scale(0.7);
  ModuleArray<ModuleCommand> commands(4);
  for (int i = 0; i < 4; ++i) commands[i].wheel_speed = 1.0 / params.layout.wheel_radius();
  int updates = 0;
  for (int k = 0; k < 60; ++k) {
    updates += estimator.observe(plant.measurement(), k * kPeriod) ? 1 : 0;
    estimator.commanded(commands, k * kPeriod);
    ASSERT_TRUE(plant.advance(commands));
  }
  EXPECT_GT(updates, 50);  // it did judge the periods
  EXPECT_NEAR(estimator.scale(), 0.7, 0.01);
}

TEST(FrictionEstimator, AMeasurementWithoutTheCommandsOfItsPeriodOrAfterAGapUpdatesNothing) {
  const VehicleParams params = testing::make_params(4);
  FrictionEstimator estimator(params, lagged_prediction(), kPeriod, exact_sensor_options());
  Eigen::VectorXd measured = Eigen::VectorXd::Zero(10);
  measured[StateIndex::kVx] = 1.0;
  ModuleArray<ModuleCommand> commands(4);
  EXPECT_FALSE(estimator.observe(measured, 0.0));
  EXPECT_FALSE(estimator.observe(measured, kPeriod));  // no command was sent at 0
  estimator.commanded(commands, kPeriod);
  EXPECT_FALSE(estimator.observe(measured, 2 * kPeriod));  // the first period of a chain only starts it
  estimator.commanded(commands, 2 * kPeriod);
  EXPECT_TRUE(estimator.observe(measured, 3 * kPeriod));
  estimator.commanded(commands, 3 * kPeriod);
  EXPECT_FALSE(estimator.observe(measured, 5 * kPeriod));  // a skipped period breaks the chain
  measured[StateIndex::kVx] = std::nan("");
  EXPECT_FALSE(estimator.observe(measured, 6 * kPeriod));
}

TEST(FrictionEstimator, BadOptionsAndAKnownGripOutsideTheBoundsAreRefusedNamingThem) {
  const VehicleParams params = testing::make_params(4);
  FrictionEstimationOptions options;
  options.min_scale = 0.0;
  EXPECT_NE(testing::config_error_of([&] { FrictionEstimator(params, PredictionOptions{}, kPeriod, options); })
                .find("FrictionEstimationOptions.min_scale = 0"),
            std::string::npos);
  options = FrictionEstimationOptions{};
  options.memory = -1.0;
  EXPECT_NE(testing::config_error_of([&] { options.validate(); }).find("memory = -1"), std::string::npos);
  EXPECT_NE(testing::config_error_of([&] { FrictionEstimator(params, PredictionOptions{}, 0.0, FrictionEstimationOptions{}); })
                .find("control_period = 0"),
            std::string::npos);
  FrictionEstimator estimator(params, PredictionOptions{}, kPeriod, FrictionEstimationOptions{});
  EXPECT_NE(testing::config_error_of([&] { estimator.set_scale(3.0); }).find("scale = 3"), std::string::npos);
  EXPECT_NE(testing::config_error_of([&] { estimator.set_scale(std::nan("")); }).find("scale = nan"), std::string::npos);
  estimator.set_scale(0.5);
  estimator.reset();
  EXPECT_EQ(estimator.scale(), 0.5);  // a new run on the same floor
}

}  // namespace
}  // namespace swerve
