// The MPC's prediction model against the plant it stands for: the same dynamic model integrated by
// RK4 at a fine step. Stage wear is what the wear term optimises, so it must not be off by large
// factors anywhere the controller operates (start-up, slow motion, cruise, corners).
#include "swerve/ocp/twist_prediction_model.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

#include <gtest/gtest.h>

#include <memory>

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

#include "support/model_fixtures.hpp"
#include "support/two_threads.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/semi_implicit_step_jacobian.hpp"
#include "swerve/sim/simulator.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

struct WearPair {
  double predicted = 0.0, plant = 0.0;
};

VehicleParams small_agv(bool actuator_lag) {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(0.6, 0.5, 0.1));
  params.mass = 160.0;
  params.yaw_inertia = 8.0;
  params.plant.actuator_lag = actuator_lag;
  return params;
}

// The 4-module state moving with `twist`, every wheel along its own velocity.
Eigen::VectorXd moving_with(const VehicleParams& params, const Eigen::Vector3d& twist) {
  Eigen::VectorXd x = Eigen::VectorXd::Zero(10);
  x.segment<3>(StateIndex::kVx) = twist;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d& p = params.layout.position_body(i);
    x[StateIndex::steering(i)] = std::atan2(twist.y() + twist.z() * p.x(), twist.x() - twist.z() * p.y());
  }
  return x;
}

// One controller step (0.05 s) of `command` from a state moving with `twist` (wheels along it),
// with ideal actuators on both sides (the prediction then charges the whole energy balance).
WearPair stage_wear(const Eigen::Vector3d& twist, const Eigen::Vector3d& command) {
  const VehicleParams params = small_agv(false);
  const TwistPredictionModel prediction(params);
  const VehicleModel<double> model(params, Fidelity::kIdeal);
  const DiscreteDynamics<double> plant(model, IntegratorMethod::kRk4);
  Eigen::VectorXd x = moving_with(params, twist), x_next(10), u(8);
  prediction.module_inputs(x, command, 0.05, u);
  WearPair w;
  EXPECT_TRUE(testing::step_once(prediction, x, command, 0.05, x_next, &w.predicted));
  EXPECT_EQ(plant.step(x, u, 0.05, 2000, x_next, &w.plant), ModelStatus::kOk);
  std::printf("[          ] twist (%.2f %.2f %.2f) -> (%.2f %.2f %.2f): predicted %.5f J, plant %.5f J\n", twist.x(),
              twist.y(), twist.z(), command.x(), command.y(), command.z(), w.predicted, w.plant);
  return w;
}

TEST(VehiclePredictionModel, StageWearOfAStartUpIncludesTheTireTransient) {
  // From rest to 0.5 m/s in one step: most of the wear is the millisecond transient that the
  // implicit step steps over; the end-of-step rate alone was 25x low here.
  const WearPair w = stage_wear({0.0, 0.0, 0.0}, {0.5, 0.0, 0.0});
  EXPECT_NEAR(w.predicted, w.plant, 0.15 * w.plant);
}

TEST(VehiclePredictionModel, StageWearOfLargeCommandChangesIsWithinTwentyPercent) {
  // A speed-and-turn change at cruise, and a diagonal start-up. (Small changes at cruise are less
  // accurate with one implicit step: a 0.05 rad/s yaw-rate change at 0.5 m/s is predicted 6x low.)
  for (const auto& [twist, command] : {std::pair<Eigen::Vector3d, Eigen::Vector3d>{{0.5, 0.0, 0.0}, {0.6, 0.0, 0.3}},
                                       {{0.0, 0.0, 0.0}, {0.3, 0.3, 0.0}}}) {
    const WearPair w = stage_wear(twist, command);
    EXPECT_NEAR(w.predicted, w.plant, 0.2 * w.plant);
  }
}

TEST(VehiclePredictionModel, SlowMotionStageWearIsWithinTwentyPercent) {
  // Under 0.25 m/s the model takes five substeps (measured: within 2 %); with one, these were 20x
  // low and 7x high.
  for (const auto& [twist, command] : {std::pair<Eigen::Vector3d, Eigen::Vector3d>{{0.1, 0.0, 0.0}, {0.15, 0.0, 0.0}},
                                       {{0.15, 0.0, 0.05}, {0.2, 0.0, 0.1}}}) {
    const WearPair w = stage_wear(twist, command);
    EXPECT_NEAR(w.predicted, w.plant, 0.2 * w.plant);
  }
}

// The same step against the simulated plant with its actuators' first-order lag (the prediction
// knows the lag only through the wear share of a command change): the plant runs several periods
// of `command` after settling at `twist`, and its wear over the first commanded period is compared.
struct LaggedWear {
  double predicted = 0.0;         // with the lagged share (the drives' lag known)
  double predicted_unscaled = 0.0;  // the whole energy balance (ideal drives assumed)
  double plant = 0.0;
};

LaggedWear lagged_stage_wear(const Eigen::Vector3d& twist, const Eigen::Vector3d& command) {
  const VehicleParams params = small_agv(true);
  const TwistPredictionModel prediction(params);
  const TwistPredictionModel unscaled(small_agv(false));
  Eigen::VectorXd x = moving_with(params, twist), x_next(10), u(8);
  prediction.module_inputs(x, command, 0.05, u);
  LaggedWear w;
  EXPECT_TRUE(testing::step_once(prediction, x, command, 0.05, x_next, &w.predicted));
  EXPECT_TRUE(testing::step_once(unscaled, x, command, 0.05, x_next, &w.predicted_unscaled));
  SimulatorOptions options;
  options.control_period = 0.05;
  Simulator plant(params, options);
  plant.reset(x);  // wheels rolling without slip at `twist`, actuators settled there
  ModuleArray<ModuleCommand> commands(4);
  for (int i = 0; i < 4; ++i) {
    commands[i].steering_rate = u[InputIndex::steering_rate(i)];
    commands[i].wheel_speed = u[InputIndex::wheel_speed(i)];
  }
  // The wear of a command change lasts as long as the drives take to follow it (~3 lags), so the
  // plant holds the command for 0.3 s (steady motion adds nothing) and the prediction's one step
  // must account for all of it.
  ModuleArray<ModuleCommand> hold = commands;
  for (int i = 0; i < 4; ++i) hold[i].steering_rate = 0.0;
  EXPECT_TRUE(plant.advance(commands));
  for (int k = 0; k < 5; ++k) EXPECT_TRUE(plant.advance(hold));
  w.plant = std::accumulate(plant.module_wear().begin(), plant.module_wear().end(), 0.0);
  std::printf("[          ] lagged drives: twist (%.2f %.2f %.2f) -> (%.2f %.2f %.2f): predicted %.5f J (unscaled %.5f J), "
              "plant %.5f J\n",
              twist.x(), twist.y(), twist.z(), command.x(), command.y(), command.z(), w.predicted, w.predicted_unscaled,
              w.plant);
  return w;
}

TEST(VehiclePredictionModel, StageWearOfASmallCorrectionAtCruiseIsNearerThePlantWithLaggedDrives) {
  // Regression (issue 15): a 2 cm/s sideways correction and a small speed change at cruise. Charged
  // as an instantaneous change (the whole energy balance) they were predicted 5-13x the wear of
  // the plant, whose drives follow through a 50 ms lag, and the controller let the tracking go
  // rather than correct. With the lagged share: 1.1-3.4x (measured 3.4, 2.5, 1.1; the rest is the
  // end-of-step wear rate, which the implicit step still over-predicts for a lagged drive).
  for (const auto& [twist, command] : {std::pair<Eigen::Vector3d, Eigen::Vector3d>{{0.8, 0.0, 0.0}, {0.8, 0.02, 0.0}},
                                       {{0.8, 0.0, 0.0}, {0.85, 0.0, 0.0}},
                                       {{0.6, 0.0, 0.1}, {0.6, 0.02, 0.12}}}) {
    const LaggedWear w = lagged_stage_wear(twist, command);
    EXPECT_GT(w.predicted_unscaled, 4.0 * w.plant);  // the defect this fixes
    EXPECT_LT(w.predicted, w.predicted_unscaled / 2.5);
    EXPECT_LT(w.predicted, 4.0 * w.plant);
    EXPECT_GT(w.predicted, 0.8 * w.plant);
  }
}

// The wheel speed a drive reaches from `start` under `command` over `dt`, and (`mean`) its mean
// over the step: the plant's drive law omega_dot = clamp((command - omega) / tau, +-alpha),
// integrated by explicit Euler at 1 us.
double drive_by_euler(double start, double command, double tau, double alpha, double dt, double* mean = nullptr) {
  constexpr double kH = 1e-6;
  const int steps = static_cast<int>(std::lround(dt / kH));
  double omega = start, sum = 0.0;
  for (int k = 0; k < steps; ++k) {
    const double next = omega + kH * std::clamp((command - omega) / tau, -alpha, alpha);
    sum += 0.5 * (omega + next);
    omega = next;
  }
  if (mean != nullptr) *mean = sum / steps;
  return omega;
}

TEST(VehiclePredictionModel, WithDriveLagTheWheelSpeedsFollowTheirCommandsThroughTheDrivesLagAndClamp) {
  // drive_lag: the wheel speeds are states (x[10..13]). tau = 50 ms, clamp 2 m/s^2 / 0.1 m =
  // 20 rad/s^2, so it holds while the wheel is more than 1 rad/s off: commands 0.5 and -0.5 rad/s
  // off stay under it, 3 rad/s off stays clamped all step, 1.5 rad/s off leaves it after 25 ms.
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.drive_lag = true;
  const VehiclePredictionModel model(params, options);
  ASSERT_EQ(model.state_size(), 14);
  Eigen::VectorXd x(14), x_next(14), u = Eigen::VectorXd::Zero(8);
  x << moving_with(params, Eigen::Vector3d(0.5, 0.0, 0.0)), Eigen::VectorXd::Constant(4, 5.0);
  const double offsets[] = {0.5, -0.5, 3.0, 1.5};
  for (int i = 0; i < 4; ++i) u[InputIndex::wheel_speed(i)] = 5.0 + offsets[i];
  double wear = 0.0;
  ASSERT_TRUE(testing::step_once(model, x, u, 0.05, x_next, &wear));
  const double alpha = params.layout.limits().max_drive_acceleration / params.layout.wheel_radius();
  for (int i = 0; i < 4; ++i) {
    const double expected = drive_by_euler(5.0, 5.0 + offsets[i], params.actuators.drive_time_constant, alpha, 0.05);
    EXPECT_NEAR(x_next[10 + i], expected, 1e-5) << "module " << i << ", command " << offsets[i] << " rad/s off";
  }
  // The body moves as the implicit step under drives at their commands at once moves it when
  // commanded the speeds the wheels reach at the step's end (the drive law's, by Euler at 1 us).
  const VehiclePredictionModel instant(params);
  Eigen::VectorXd instant_next(10), end_inputs = u;
  for (int i = 0; i < 4; ++i) {
    end_inputs[InputIndex::wheel_speed(i)] =
        drive_by_euler(5.0, 5.0 + offsets[i], params.actuators.drive_time_constant, alpha, 0.05);
  }
  ASSERT_TRUE(testing::step_once(instant, x.head(10), end_inputs, 0.05, instant_next, &wear));
  EXPECT_LT((x_next.head(10) - instant_next).cwiseAbs().maxCoeff(), 1e-4);
  // Lagging wheels drive the body less than the commands at once would.
  ASSERT_TRUE(testing::step_once(instant, x.head(10), u, 0.05, instant_next, &wear));
  EXPECT_LT(x_next[StateIndex::kVx], instant_next[StateIndex::kVx] - 1e-3);
  // A state without the wheel speeds is refused.
  EXPECT_FALSE(testing::step_once(model, x.head(10), u, 0.05, instant_next, &wear));
}

TEST(VehiclePredictionModel, WithDriveLagTheWearOfSmallCorrectionsAtCruiseStaysNearThePlants) {
  // A command change at cruise, held for 0.3 s (the drives take ~3 lags to follow it): six
  // prediction steps with the wheel speeds as lagged states against the plant with lagging drives.
  // Measured: 3.4, 0.94, 3.1 and 3.3x for the small corrections, 1.00x for a large change (the
  // excess is the end-of-step wear rate of the implicit step, as without drive_lag).
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.drive_lag = true;
  const VehiclePredictionModel lagged(params, options);
  const TwistPredictionModel twist_map(params);
  for (const auto& [twist, command] : {std::pair<Eigen::Vector3d, Eigen::Vector3d>{{0.8, 0.0, 0.0}, {0.8, 0.02, 0.0}},
                                       {{0.8, 0.0, 0.0}, {0.85, 0.0, 0.0}},
                                       {{0.6, 0.0, 0.1}, {0.6, 0.02, 0.12}},
                                       {{0.8, 0.0, 0.0}, {0.8, 0.1, 0.0}},
                                       {{0.3, 0.0, 0.0}, {0.5, 0.1, 0.2}}}) {
    const Eigen::VectorXd start = moving_with(params, twist);
    Eigen::VectorXd u(8), x(14), x_next(14);
    twist_map.module_inputs(start, command, 0.05, u);
    x << start, Eigen::VectorXd::Zero(4);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector2d& p = params.layout.position_body(i);
      x[10 + i] = std::hypot(twist.x() - twist.z() * p.y(), twist.y() + twist.z() * p.x()) / 0.1;  // rolling
    }
    double predicted = 0.0;
    for (int k = 0; k < 6; ++k) {
      double wear = 0.0;
      ASSERT_TRUE(testing::step_once(lagged, x, u, 0.05, x_next, &wear));
      predicted += wear;
      x = x_next;
      for (int i = 0; i < 4; ++i) u[InputIndex::steering_rate(i)] = 0.0;  // then held
    }
    const double plant = lagged_stage_wear(twist, command).plant;
    std::printf("[          ] drive_lag, 0.3 s: predicted %.5f J, plant %.5f J (%.2fx)\n", predicted, plant,
                predicted / plant);
    EXPECT_GT(predicted, 0.8 * plant);
    EXPECT_LT(predicted, 4.0 * plant);
  }
}

TEST(VehiclePredictionModel, WithDriveLagARampsWearOverAHorizonStaysNearThePlants) {
  // Regression (issue 15): a planner's ramp, 0.5 to 1 m/s at 0.5 m/s^2 over one second, straight
  // ahead, the drives lagging 50 ms. The plant's body trails its wheels by a tau_t (tau_t = m / c of
  // the tyres, ~7 ms here), steadily. The implicit step used to run on each wheel's mean speed over
  // the step, which left its body a h / 2 further behind the wheel state than the plant's, and a
  // 20-step rollout of a logged ramp priced it 1.4-3x the plant (2.1x from rest on the paper's
  // vehicle; 1.32x on this ramp). On the wheels' end speeds, with the drives' work on their mean:
  // measured 1.04x here.
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.drive_lag = true;
  const VehiclePredictionModel lagged(params, options);
  const Eigen::VectorXd start = moving_with(params, {0.5, 0.0, 0.0});
  Eigen::VectorXd x(14), x_next(14), u = Eigen::VectorXd::Zero(8);
  x << start, Eigen::VectorXd::Constant(4, 5.0);
  SimulatorOptions simulator_options;
  simulator_options.control_period = 0.05;
  Simulator plant(params, simulator_options);
  plant.reset(start);  // wheels rolling at 0.5 m/s, actuators settled there
  ModuleArray<ModuleCommand> commands(4);
  double predicted = 0.0;
  for (int k = 0; k < 20; ++k) {
    const double wheel_speed = (0.5 + 0.5 * 0.05 * (k + 1)) / 0.1;
    for (int i = 0; i < 4; ++i) {
      u[InputIndex::wheel_speed(i)] = wheel_speed;
      commands[i].wheel_speed = wheel_speed;
    }
    double wear = 0.0;
    ASSERT_TRUE(testing::step_once(lagged, x, u, 0.05, x_next, &wear));
    predicted += wear;
    x = x_next;
    ASSERT_TRUE(plant.advance(commands));
  }
  const double worn = std::accumulate(plant.module_wear().begin(), plant.module_wear().end(), 0.0);
  std::printf("[          ] 1 s ramp: predicted %.5f J, plant %.5f J (%.2fx)\n", predicted, worn,
              predicted / worn);
  EXPECT_GT(worn, 0.0);
  EXPECT_NEAR(predicted, worn, 0.15 * worn);
  // The rollout's body speed follows the plant's: 1 m/s less the lags.
  EXPECT_NEAR(x[StateIndex::kVx], plant.state()[StateIndex::kVx], 0.005);
}

TEST(VehiclePredictionModel, WithSteeringLagTheAnglesAdvanceByTheLaggedRatesMean) {
  // steering_lag: the steering rates are states (x[10..13] without drive_lag). A rate r0 towards a
  // command c through tau: r(t) = c + (r0 - c) e^-t/tau, so over h the angle moves
  // c h + (r0 - c) tau (1 - e^-h/tau) and the rate ends at c + (r0 - c) e^-h/tau.
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.steering_lag = true;
  const VehiclePredictionModel model(params, options);
  ASSERT_EQ(model.state_size(), 14);
  const double tau = params.actuators.steering_time_constant, h = 0.05;
  Eigen::VectorXd x(14), x_next(14), u(8);
  x << moving_with(params, Eigen::Vector3d(0.5, 0.0, 0.0)), 0.0, 0.4, -0.3, 0.2;
  const double commands[] = {0.5, 0.4, 0.3, -0.6};
  for (int i = 0; i < 4; ++i) {
    u[InputIndex::steering_rate(i)] = commands[i];
    u[InputIndex::wheel_speed(i)] = 5.0;
  }
  double wear = 0.0;
  ASSERT_TRUE(testing::step_once(model, x, u, h, x_next, &wear));
  const double decay = std::exp(-h / tau);
  for (int i = 0; i < 4; ++i) {
    const double r0 = x[10 + i], c = commands[i];
    EXPECT_NEAR(x_next[StateIndex::steering(i)] - x[StateIndex::steering(i)],
                c * h + (r0 - c) * tau * (1.0 - decay), 1e-12)
        << "module " << i;
    EXPECT_NEAR(x_next[10 + i], c + (r0 - c) * decay, 1e-12) << "module " << i;
  }
  // Without the lag the angle moves c h, the rate a command at once.
  const VehiclePredictionModel instant(params);
  Eigen::VectorXd instant_next(10);
  ASSERT_TRUE(testing::step_once(instant, x.head(10), u, h, instant_next, &wear));
  EXPECT_NEAR(instant_next[StateIndex::steering(0)] - x[StateIndex::steering(0)], 0.5 * h, 1e-12);
  // A state without the steering rates is refused.
  EXPECT_FALSE(testing::step_once(model, x.head(10), u, h, instant_next, &wear));
}

TEST(VehiclePredictionModel, WithSteeringLagASteeringSwingAtWalkingPaceCostsWhatThePlantWears) {
  // Regression (issue 15): the annealer's start-up plans swung the modules +-0.05 rad at 0.1-0.2
  // m/s, and on curve_smooth that cost 0.69 J in the first second where the baseline wore 0.44 J
  // (0.43 J once the prediction knew the steering lag). The plant's steering follows its rate
  // command through a 50 ms lag, so its angles are not the ones a prediction that steers at the
  // commanded rate at once rolls out, and that prediction's price of a swing is not the plant's
  // (measured here: 5.0x, against 1.00x with the lag). At 0.15 m/s: +1 rad/s for a step, -1 for
  // two, +1 for one, then hold; five steps of each.
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.drive_lag = true;
  const VehiclePredictionModel instant_steering(params, options);
  options.steering_lag = true;
  const VehiclePredictionModel lagged_steering(params, options);
  const Eigen::VectorXd start = moving_with(params, {0.15, 0.0, 0.0});
  SimulatorOptions simulator_options;
  simulator_options.control_period = 0.05;
  Simulator plant(params, simulator_options);
  plant.reset(start);
  Eigen::VectorXd x_instant(14), x_lagged(18), next_instant(14), next_lagged(18), u(8);
  x_instant << start, Eigen::VectorXd::Constant(4, 1.5);
  x_lagged << start, Eigen::VectorXd::Constant(4, 1.5), Eigen::VectorXd::Zero(4);
  ModuleArray<ModuleCommand> commands(4);
  double instant_wear = 0.0, lagged_wear = 0.0;
  const double rates[] = {1.0, -1.0, -1.0, 1.0, 0.0};
  for (const double rate : rates) {
    for (int i = 0; i < 4; ++i) {
      u[InputIndex::steering_rate(i)] = rate;
      u[InputIndex::wheel_speed(i)] = 1.5;
      commands[i].steering_rate = rate;
      commands[i].wheel_speed = 1.5;
    }
    double wear = 0.0;
    ASSERT_TRUE(testing::step_once(instant_steering, x_instant, u, 0.05, next_instant, &wear));
    instant_wear += wear;
    ASSERT_TRUE(testing::step_once(lagged_steering, x_lagged, u, 0.05, next_lagged, &wear));
    lagged_wear += wear;
    x_instant = next_instant;
    x_lagged = next_lagged;
    ASSERT_TRUE(plant.advance(commands));
  }
  const double worn = std::accumulate(plant.module_wear().begin(), plant.module_wear().end(), 0.0);
  std::printf(
      "[          ] steering swing at 0.15 m/s: plant %.6f J, lagged steering %.6f J (%.2fx), "
      "instant steering %.6f J (%.2fx)\n",
      worn, lagged_wear, lagged_wear / worn, instant_wear, instant_wear / worn);
  EXPECT_NEAR(lagged_wear, worn, 0.3 * worn);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(x_lagged[StateIndex::steering(i)], plant.state()[StateIndex::steering(i)], 1e-3)
        << "module " << i;
  }
}

TEST(VehiclePredictionModel, WithDriveLagWheelsAtTheirCommandsPredictWhatInstantDrivesPredict) {
  // Nothing for the lag to do: the body, steering and wear are those of the model without it.
  const VehicleParams params = small_agv(true);
  PredictionOptions options;
  options.drive_lag = true;
  const VehiclePredictionModel lagged(params, options), instant(params);
  Eigen::VectorXd x(14), x_next(14), instant_next(10), u(8);
  const Eigen::Vector3d twist(0.6, 0.05, 0.2);
  x.head(10) = moving_with(params, twist);
  instant.module_inputs(x.head(10), twist, 0.05, u);
  for (int i = 0; i < 4; ++i) x[10 + i] = u[InputIndex::wheel_speed(i)];
  double lagged_wear = 0.0, instant_wear = 0.0;
  ASSERT_TRUE(testing::step_once(lagged, x, u, 0.05, x_next, &lagged_wear));
  ASSERT_TRUE(testing::step_once(instant, x.head(10), u, 0.05, instant_next, &instant_wear));
  EXPECT_LT((x_next.head(10) - instant_next).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GT(instant_wear, 0.0);
  EXPECT_NEAR(lagged_wear, instant_wear, 1e-12);
  EXPECT_LT((x_next.tail(4) - x.tail(4)).cwiseAbs().maxCoeff(), 1e-12);
}

// From rest, wheels that spin up while their modules still turn slip far past the tyre's force
// peak, where the backward-Euler residual is not monotone. Newton's method then once wandered for
// eight iterations and its unconverged iterate was returned as the step: a 4 cm/s command
// predicted 6.5 m/s. The step is now split where Newton finds no root, so no commanded start-up
// predicts a body speed beyond what its wheels are told.
TEST(VehiclePredictionModel, AStartUpFromRestNeverPredictsASpeedBeyondTheCommand) {
  const VehicleParams params = testing::make_params(
      ModuleLayout::multi_axle(2, 0.6, 0.5, 0.1, ModuleLimits{2.0, 2.0, 3.0, -kPi, kPi}));
  const TwistPredictionModel model(params);
  std::mt19937_64 random(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  double fastest_predicted = 0.0;
  for (int sequence = 0; sequence < 64; ++sequence) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(model.state_size()), x_next = x;
    double fastest_commanded = 0.0;
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d twist(0.5 * (k + 1) / 20.0 + noise(random), noise(random), noise(random));
      fastest_commanded = std::max(fastest_commanded, twist.head<2>().norm() + 0.5 * std::abs(twist.z()));
      double wear = 0.0;
      ASSERT_TRUE(testing::step_once(model, x, twist, 0.05, x_next, &wear)) << "sequence " << sequence << ", stage " << k;
      const double speed = x_next.segment<2>(StateIndex::kVx).norm();
      fastest_predicted = std::max(fastest_predicted, speed);
      EXPECT_LE(speed, fastest_commanded + 0.05) << "sequence " << sequence << ", stage " << k;
      x.swap(x_next);
    }
  }
  std::printf("[          ] fastest predicted body speed %.3f m/s\n", fastest_predicted);
}

// The model is immutable and its scratch belongs to the caller (issue 16): rollouts with a Data
// each, on two threads at once, give bit for bit what one thread gives.
TEST(VehiclePredictionModel, RolloutsWithTheirOwnDataOnTwoThreadsMatchOneThreadBitForBit) {
  const VehicleParams params = small_agv(true);
  const VehiclePredictionModel model(params);
  constexpr int kSequences = 32, kStages = 20;
  std::mt19937_64 random(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<Eigen::MatrixXd> twists(kSequences, Eigen::MatrixXd(3, kStages));
  for (int s = 0; s < kSequences; ++s) {
    for (int k = 0; k < kStages; ++k) {
      // Even sequences start from rest (slow-motion substeps), odd ones cruise along an arc.
      const double speed = s % 2 == 0 ? 0.6 * (k + 1) / kStages : 0.8;
      twists[static_cast<std::size_t>(s)].col(k) = Eigen::Vector3d(speed + noise(random), noise(random), 0.3 + noise(random));
    }
  }
  const auto rollout = [&](PredictionData& data, int s, Eigen::VectorXd* final_state, double* wear) {
    Eigen::VectorXd x = s % 2 == 0 ? Eigen::VectorXd::Zero(10) : moving_with(params, {0.8, 0.0, 0.3});
    Eigen::VectorXd x_next = x;
    *wear = 0.0;
    for (int k = 0; k < kStages; ++k) {
      double stage_wear = 0.0;
      if (!model.twist_step(data, x, twists[static_cast<std::size_t>(s)].col(k), 0.05, x_next, &stage_wear)) return false;
      *wear += stage_wear;
      x.swap(x_next);
    }
    *final_state = x;
    return true;
  };
  std::vector<Eigen::VectorXd> expected_states(kSequences);
  std::vector<double> expected_wear(kSequences);
  {
    const std::unique_ptr<PredictionData> data = model.create_data();
    for (int s = 0; s < kSequences; ++s) {
      ASSERT_TRUE(rollout(*data, s, &expected_states[static_cast<std::size_t>(s)], &expected_wear[static_cast<std::size_t>(s)]));
    }
  }
  // Each thread runs every sequence three times.
  const auto mismatches = testing::mismatches_on_two_threads(
      kSequences, 3, [&] { return model.create_data(); },
      [&](const std::unique_ptr<PredictionData>& data, int s) {
        const auto index = static_cast<std::size_t>(s);
        Eigen::VectorXd state;
        double wear = 0.0;
        return rollout(*data, s, &state, &wear) && state == expected_states[index] && wear == expected_wear[index];
      });
  EXPECT_EQ(mismatches[0], 0);
  EXPECT_EQ(mismatches[1], 0);
}

TEST(VehiclePredictionModel, ChargesItsClockModulesTimesTheEvaluationsEachStepTook) {
  // A work clock prices a rollout by what it evaluates: four modules cost four per evaluation, and
  // a slow step (five substeps) more than a cruising one.
  const VehicleParams params = small_agv(true);
  VehiclePredictionModel model(params);
  const WorkClock clock(0.0, 1e-6);
  model.charge_work_to(&clock);
  const std::unique_ptr<PredictionData> data = model.create_data();
  Eigen::VectorXd x_next(model.state_size());
  double wear = 0.0;
  const auto charged_step = [&](const Eigen::VectorXd& x, const Eigen::Vector3d& twist, long* evaluations) {
    const long before = VehiclePredictionModel::model_evaluations(*data);
    const TimePoint start = clock.now();
    EXPECT_TRUE(model.twist_step(*data, x, twist, 0.05, x_next, &wear));
    *evaluations = VehiclePredictionModel::model_evaluations(*data) - before;
    return to_seconds(clock.now() - start);
  };
  long cruise_evaluations = 0, slow_evaluations = 0;
  const double cruise = charged_step(moving_with(params, {0.8, 0.0, 0.3}), {0.8, 0.0, 0.3}, &cruise_evaluations);
  const double slow = charged_step(Eigen::VectorXd::Zero(model.state_size()), {0.05, 0.0, 0.0}, &slow_evaluations);
  ASSERT_GT(cruise_evaluations, 0);
  EXPECT_NEAR(cruise, 4e-6 * static_cast<double>(cruise_evaluations), 1e-9);
  EXPECT_NEAR(slow, 4e-6 * static_cast<double>(slow_evaluations), 1e-9);
  EXPECT_GT(slow_evaluations, cruise_evaluations);
  // A Jacobian at the cruising point is charged, per module, the same twist solve's evaluations,
  // its one substep's linearisation and its Jet chunks; nothing once the clock is unwired.
  Eigen::MatrixXd a(model.state_size(), model.state_size()), b(model.state_size(), 3);
  Eigen::VectorXd wear_gradient(model.state_size() + 3);
  TimePoint start = clock.now();
  ASSERT_TRUE(model.twist_step_jacobians(*data, moving_with(params, {0.8, 0.0, 0.3}), {0.8, 0.0, 0.3}, 0.05,
                                         x_next, a, b, &wear, wear_gradient));
  const double per_module = static_cast<double>(cruise_evaluations) +
                            VehiclePredictionModel::module_evaluations_per_linearisation() +
                            VehiclePredictionModel::module_evaluations_per_jet_chunk() *
                                SemiImplicitStepJacobian::chunks(model.state_size() + 3);
  EXPECT_NEAR(to_seconds(clock.now() - start), 4e-6 * per_module, 1e-9);
  model.charge_work_to(nullptr);
  start = clock.now();
  EXPECT_TRUE(model.twist_step(*data, moving_with(params, {0.8, 0.0, 0.3}), {0.8, 0.0, 0.3}, 0.05, x_next, &wear));
  EXPECT_EQ(clock.now(), start);
}

TEST(VehiclePredictionModel, SteadyMotionWearsNothingInPredictionAndPlant) {
  const WearPair w = stage_wear({0.5, 0.0, 0.0}, {0.5, 0.0, 0.0});
  EXPECT_NEAR(w.predicted, 0.0, 1e-9);
  EXPECT_NEAR(w.plant, 0.0, 1e-9);
}

TEST(VehiclePredictionModel, AFrictionScaleOnEveryModulePredictsAsAVehicleWithThatMuSteppingAndLinearising) {
  // Independent truth: a model built with the tire's mu scaled. The scale reaches every model the
  // step evaluates: the twist solve in Jets and in double, the linearisation behind the Jacobians,
  // and the tyres' slip stiffness in the lagged wear share.
  const VehicleParams params = testing::make_params(4);
  VehicleParams slippery = params;
  slippery.tire.mu = 0.6 * params.tire.mu;
  PredictionOptions options;
  options.drive_lag = true;
  options.steering_lag = true;
  VehiclePredictionModel scaled(params, options);
  const VehiclePredictionModel truth(slippery, options), dry(params, options);
  const double scales[4] = {0.6, 0.6, 0.6, 0.6};
  scaled.observe_friction_scales(scales);
  const int nx = truth.state_size(), nu = truth.input_size();
  Eigen::VectorXd x = Eigen::VectorXd::Zero(nx), u = Eigen::VectorXd::Zero(nu);
  x[StateIndex::kVx] = 0.8;
  x[StateIndex::kYawRate] = 0.3;
  for (int i = 0; i < 4; ++i) {
    x[StateIndex::steering(i)] = 0.1 * (i + 1);
    u[InputIndex::steering_rate(i)] = 0.4;
    u[InputIndex::wheel_speed(i)] = 1.2 / params.layout.wheel_radius();
  }
  x.tail(nx - 10).setConstant(0.5);
  auto data = scaled.create_data(), truth_data = truth.create_data(), dry_data = dry.create_data();
  Eigen::VectorXd next(nx), truth_next(nx), dry_next(nx), gradient(nx + nu), truth_gradient(nx + nu);
  Eigen::MatrixXd a(nx, nx), b(nx, nu), truth_a(nx, nx), truth_b(nx, nu);
  double wear = 0.0, truth_wear = 0.0, dry_wear = 0.0;
  ASSERT_TRUE(scaled.step_jacobians(*data, x, u, 0.05, next, a, b, &wear, gradient));
  ASSERT_TRUE(truth.step_jacobians(*truth_data, x, u, 0.05, truth_next, truth_a, truth_b, &truth_wear, truth_gradient));
  ASSERT_TRUE(dry.step(*dry_data, x, u, 0.05, dry_next, &dry_wear));
  EXPECT_LT((next - truth_next).norm(), 1e-9);
  EXPECT_NEAR(wear, truth_wear, 1e-9 * truth_wear);
  EXPECT_LT((a - truth_a).norm(), 1e-6 * truth_a.norm());
  EXPECT_LT((b - truth_b).norm(), 1e-6 * truth_b.norm());
  EXPECT_LT((gradient - truth_gradient).norm(), 1e-6 * truth_gradient.norm());
  EXPECT_GT(std::abs(wear - dry_wear), 1e-3 * dry_wear);  // the grip matters here
}

}  // namespace
}  // namespace swerve
