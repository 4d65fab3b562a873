// drive_response, the closed form of a drive's first-order lag with its acceleration clamp, held to
// the vehicle model's own drive law (Fidelity::kPlant with actuator lag and saturation, integrated
// by RK4 at 10 us), in each of its regimes, and continuous where the regimes meet.
#include "swerve/models/drive_response.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/model_fixtures.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {
namespace {

TEST(DriveResponse, MatchesThePlantModelsDriveLawInEachRegime) {
  // tau = 50 ms, clamp 2 m/s^2 / 0.1 m = 20 rad/s^2: the clamp holds while a wheel is more than
  // 1 rad/s off its command. Wheels at 5 rad/s commanded 0.5 and -0.5 rad/s off (never clamped),
  // 3 rad/s off (clamped all step) and 1.5 rad/s off (clamped for the first 25 ms).
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
  params.plant.actuator_lag = true;
  params.plant.actuator_saturation = true;
  const VehicleModel<double> plant(params, Fidelity::kPlant);
  const DiscreteDynamics<double> dynamics(plant, IntegratorMethod::kRk4);
  const double offsets[] = {0.5, -0.5, 3.0, 1.5};
  Eigen::VectorXd x = Eigen::VectorXd::Zero(plant.state_size()), x_next(plant.state_size()), u(8);
  for (int i = 0; i < 4; ++i) {
    x[plant.wheel_speed_index(i)] = 5.0;
    u[InputIndex::steering_rate(i)] = 0.0;
    u[InputIndex::wheel_speed(i)] = 5.0 + offsets[i];
  }
  x[StateIndex::kVx] = 0.5;  // the body rolling with the wheels
  const double dt = 0.05;
  ASSERT_EQ(dynamics.step(x, u, dt, 5000, x_next, nullptr), ModelStatus::kOk);
  const DriveLag lag{params.actuators.drive_time_constant,
                     params.layout.limits().max_drive_acceleration / params.layout.wheel_radius()};
  for (int i = 0; i < 4; ++i) {
    double end = 0.0, mean = 0.0;
    drive_response(5.0, 5.0 + offsets[i], lag, dt, &end, &mean);
    EXPECT_NEAR(end, x_next[plant.wheel_speed_index(i)], 1e-8) << "command " << offsets[i] << " rad/s off";
    // The mean lies between start and end (the speed moves monotonically towards the command).
    EXPECT_GT((mean - 5.0) * offsets[i], 0.0);
    EXPECT_LT((mean - end) * offsets[i], 0.0);
  }
}

TEST(DriveResponse, IsContinuousWhereTheClampLetsGo) {
  // At |command - start| = alpha tau the clamped and unclamped pieces meet: end and mean agree on
  // either side to first order. Likewise where the clamp lasts exactly the whole step.
  const DriveLag lag{0.05, 20.0};
  const double dt = 0.05;
  for (const double edge : {lag.max_acceleration * lag.time_constant,
                            lag.max_acceleration * (lag.time_constant + dt)}) {
    double end_below = 0.0, mean_below = 0.0, end_above = 0.0, mean_above = 0.0;
    drive_response(0.0, edge * (1.0 - 1e-9), lag, dt, &end_below, &mean_below);
    drive_response(0.0, edge * (1.0 + 1e-9), lag, dt, &end_above, &mean_above);
    EXPECT_NEAR(end_below, end_above, 1e-7) << "edge " << edge;
    EXPECT_NEAR(mean_below, mean_above, 1e-7) << "edge " << edge;
  }
  // Without a clamp it is the plain first-order lag: e^-1 of the gap left after one time constant.
  double end = 0.0, mean = 0.0;
  drive_response(0.0, 10.0, DriveLag{0.05}, 0.05, &end, &mean);
  EXPECT_NEAR(end, 10.0 * (1.0 - std::exp(-1.0)), 1e-12);
  EXPECT_NEAR(mean, 10.0 * std::exp(-1.0), 1e-12);  // 10 (1 - (tau / dt)(1 - e^-1)) with tau = dt
}

}  // namespace
}  // namespace swerve
