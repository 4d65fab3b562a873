// The plant simulator: zero-lag plant against the model's own discrete map, determinism by seed,
// and the wear/energy integrals it keeps.
#include "swerve/sim/simulator.hpp"

#include <gtest/gtest.h>

#include <cstdio>

#include "support/model_fixtures.hpp"
#include "support/config_errors.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/models/integrators.hpp"

namespace swerve {
namespace {

VehicleParams ideal_plant_params() {
  VehicleParams params = testing::make_params(4);
  params.plant.actuator_lag = false;
  params.plant.actuator_saturation = false;
  return params;
}

ModuleArray<ModuleCommand> turning_commands(int modules) {
  ModuleArray<ModuleCommand> commands(modules);
  for (int i = 0; i < modules; ++i) {
    commands[i].steering_rate = 0.3 * (i % 2 == 0 ? 1.0 : -0.5);
    commands[i].wheel_speed = 4.0 + 0.5 * i;
  }
  return commands;
}

TEST(Simulator, ZeroLagPlantFollowsTheModelsOwnDiscreteMap) {
  const VehicleParams params = ideal_plant_params();
  SimulatorOptions options;
  options.control_period = 0.05;
  options.substeps = 40;
  Simulator simulator(params, options);
  Eigen::VectorXd prefix = Eigen::VectorXd::Zero(10);
  prefix[3] = 0.3;
  simulator.reset(prefix);

  const VehicleModel<double> model(params, Fidelity::kIdeal);
  const DiscreteDynamics<double> map(model, IntegratorMethod::kRk4);
  Eigen::VectorXd x = prefix, x_next(10);
  Eigen::VectorXd u(8);
  const ModuleArray<ModuleCommand> commands = turning_commands(4);
  for (int i = 0; i < 4; ++i) u.segment<2>(2 * i) << commands[i].steering_rate, commands[i].wheel_speed;
  double wear_total = 0.0;
  for (int k = 0; k < 10; ++k) {
    ASSERT_TRUE(simulator.advance(commands));
    double wear = 0.0;
    ASSERT_EQ(map.step(x, u, 0.05, 40, x_next, &wear), ModelStatus::kOk);
    x = x_next;
    wear_total += wear;
  }
  EXPECT_LT((simulator.state().head(10) - x).cwiseAbs().maxCoeff(), 1e-9);
  double simulated_wear = 0.0;
  for (double w : simulator.module_wear()) simulated_wear += w;
  EXPECT_NEAR(simulated_wear, wear_total, 1e-9 * (1.0 + wear_total));
  EXPECT_GT(wear_total, 0.0);  // the wheels were commanded to slip, so the comparison is not 0 == 0
  EXPECT_NEAR(simulator.time(), 0.5, 1e-12);
}

TEST(Simulator, FrictionalEnergyEqualsWearForUnitCoefficientFrictionalPowerWear) {
  // With w_dot = 1 x frictional power, wear (RK4) and energy (rectangle rule) integrate the same
  // signal: they agree to the quadrature error.
  VehicleParams params = ideal_plant_params();
  SimulatorOptions options;
  options.substeps = 200;
  Simulator simulator(params, options);
  simulator.reset(Eigen::VectorXd::Zero(10));
  for (int k = 0; k < 20; ++k) ASSERT_TRUE(simulator.advance(turning_commands(4)));
  double wear = 0.0;
  for (double w : simulator.module_wear()) wear += w;
  EXPECT_GT(wear, 0.0);
  EXPECT_NEAR(simulator.frictional_energy(), wear, 0.02 * wear);
}

// The wear of a start from rest with a relaxation length (transient slip) against the same plant
// without one: the carcass' deflection at the start stores energy and gives it back, it does not
// wear. Counted as wear (the transient force times the kinematic slip velocity), the first period
// of this start wore 31x the quasi-static plant's (0.117 J against 0.0038 J); with the sliding the
// transient slips stand for, 1.5x (0.0057 J: the force builds over the relaxation length, so the
// wheels run a little further ahead before the body follows).
TEST(Simulator, AStartFromRestWithTransientSlipWearsAboutWhatTheQuasiStaticPlantWears) {
  auto first_period_wear = [](double relaxation_length) {
    VehicleParams params = testing::make_params(4);
    params.plant.relaxation_length = relaxation_length;
    Simulator simulator(params, SimulatorOptions{});
    simulator.reset(Eigen::VectorXd::Zero(10));
    ModuleArray<ModuleCommand> commands(4);
    for (int i = 0; i < 4; ++i) commands[i].wheel_speed = 0.08 / params.layout.wheel_radius();
    EXPECT_TRUE(simulator.advance(commands));
    double wear = 0.0;
    for (double w : simulator.module_wear()) wear += w;
    return wear;
  };
  const double quasi_static = first_period_wear(0.0);
  const double transient = first_period_wear(0.05);
  std::printf("[          ] first period's wear: %.5f J without relaxation, %.5f J with 0.05 m\n", quasi_static,
              transient);
  ASSERT_GT(quasi_static, 0.0);
  EXPECT_LT(transient, 3.0 * quasi_static);
  EXPECT_GT(transient, 0.3 * quasi_static);
}

TEST(Simulator, IdenticalSeedsGiveIdenticalMeasurementsAndOtherSeedsDiffer) {
  VehicleParams params = testing::make_params(4);
  SimulatorOptions options;
  options.noise.position = 0.01;
  options.noise.steering_angle = 0.01;
  options.seed = 42;
  auto measurements = [&](std::uint64_t seed) {
    SimulatorOptions o = options;
    o.seed = seed;
    Simulator simulator(params, o);
    simulator.reset(Eigen::VectorXd::Zero(10));
    std::vector<Eigen::VectorXd> seen;
    for (int k = 0; k < 5; ++k) {
      EXPECT_TRUE(simulator.advance(turning_commands(4)));
      seen.push_back(simulator.measurement());
    }
    return seen;
  };
  const auto a = measurements(42), b = measurements(42), c = measurements(43);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k], b[k]);
    EXPECT_NE(a[k], c[k]);
  }
}

TEST(SimulatorOptions, ValidateHoldsTheSameRulesTheScenarioLoaderReads) {
  // One table for both: a delay the loader refuses (it capped at 100, validate() did not) is refused
  // in code too, and each message names the field and the value.
  const auto message = [](const SimulatorOptions& options) {
    return testing::config_error_of([&] { options.validate(); });
  };
  SimulatorOptions options;
  EXPECT_EQ(message(options), "");
  options.measurement_delay_steps = 100;
  EXPECT_EQ(message(options), "");
  options.measurement_delay_steps = 101;
  EXPECT_EQ(message(options), "SimulatorOptions.measurement_delay_steps = 101: must be in [0, 100]");
  options = SimulatorOptions{};
  options.noise.yaw_rate = -0.1;
  EXPECT_EQ(message(options), "SimulatorOptions.noise.yaw_rate = -0.1: must be finite and >= 0 (rad/s)");
  options = SimulatorOptions{};
  options.substeps = -1;
  EXPECT_EQ(message(options), "SimulatorOptions.substeps = -1: must be in [0, 100000]");
  options = SimulatorOptions{};
  options.initial_module_wear = {1.0, -2.0};
  EXPECT_EQ(message(options), "SimulatorOptions.initial_module_wear[1] = -2: must be finite and >= 0 (wear units)");
  options.initial_module_wear = {1.0, std::nan("")};
  EXPECT_NE(message(options).find("initial_module_wear[1] = "), std::string::npos);
  // Its size is the vehicle's: the plant checks it.
  options.initial_module_wear = {1.0, 2.0, 3.0};
  EXPECT_EQ(message(options), "");
  EXPECT_EQ(testing::config_error_of([&] { Simulator plant(ideal_plant_params(), options); }),
            "SimulatorOptions.initial_module_wear.size = 3: must be the vehicle's module count, 4");
}

TEST(Simulator, MeasurementDelayShowsTheStateFromEarlierPeriods) {
  VehicleParams params = ideal_plant_params();
  SimulatorOptions options;
  options.measurement_delay_steps = 2;
  Simulator simulator(params, options);
  Eigen::VectorXd prefix = Eigen::VectorXd::Zero(10);
  simulator.reset(prefix);
  std::vector<Eigen::VectorXd> truth = {simulator.state().head(10)};
  for (int k = 0; k < 4; ++k) {
    ASSERT_TRUE(simulator.advance(turning_commands(4)));
    truth.push_back(simulator.state().head(10));
    const std::size_t shown = truth.size() >= 3 ? truth.size() - 3 : 0;
    EXPECT_EQ(simulator.measurement(), truth[shown]) << "after period " << k + 1;
  }
}

TEST(Simulator, NonFiniteCommandsAreRefusedAndLeaveTheStateAsItWas) {
  Simulator simulator(ideal_plant_params(), SimulatorOptions{});
  simulator.reset(Eigen::VectorXd::Zero(10));
  const Eigen::VectorXd before = simulator.state();
  ModuleArray<ModuleCommand> commands = turning_commands(4);
  commands[2].wheel_speed = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(simulator.advance(commands));
  EXPECT_EQ(simulator.state(), before);
  EXPECT_EQ(simulator.time(), 0.0);
}

TEST(Simulator, InvalidOptionsAndInitialStatesNameTheField) {
  SimulatorOptions options;
  options.control_period = -0.05;
  try {
    Simulator simulator(ideal_plant_params(), options);
    FAIL() << "a negative control period was accepted";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("control_period = -0.05"), std::string::npos) << error.what();
  }
  options = SimulatorOptions{};
  options.noise.heading = -1.0;
  EXPECT_THROW(Simulator(ideal_plant_params(), options), ConfigError);
  Simulator simulator(ideal_plant_params(), SimulatorOptions{});
  EXPECT_THROW(simulator.reset(Eigen::VectorXd::Zero(7)), ConfigError);
  Eigen::VectorXd nan_state = Eigen::VectorXd::Zero(10);
  nan_state[4] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(simulator.reset(nan_state), ConfigError);
}

TEST(Simulator, AStuckSteeringHoldsItsAngleFromItsOnsetWhileTheOthersTurn) {
  // The plant with its steering lag: module 1 sticks at 0.2 s (the fifth period), mid-turn.
  VehicleParams params = testing::make_params(4);
  SimulatorOptions options;
  options.faults.push_back({1, 0.2, ModuleFault::kStuckSteering, false});
  Simulator simulator(params, options);
  simulator.reset(Eigen::VectorXd::Zero(10));
  ModuleArray<ModuleCommand> commands(4);
  for (int i = 0; i < 4; ++i) commands[i].steering_rate = 1.0;
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(simulator.advance(commands));
  EXPECT_EQ(simulator.active_faults()[1], ModuleFault::kNone);  // not before its onset
  const double angle_at_onset = simulator.state()[StateIndex::steering(1)];
  const double other_at_onset = simulator.state()[StateIndex::steering(0)];
  EXPECT_GT(angle_at_onset, 0.05);  // it was turning
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(simulator.advance(commands));
  EXPECT_EQ(simulator.active_faults()[1], ModuleFault::kStuckSteering);
  EXPECT_EQ(simulator.state()[StateIndex::steering(1)], angle_at_onset);
  EXPECT_GT(simulator.state()[StateIndex::steering(0)], other_at_onset + 0.4);
  // A new run starts healthy.
  simulator.reset(Eigen::VectorXd::Zero(10));
  EXPECT_EQ(simulator.active_faults()[1], ModuleFault::kNone);
}

TEST(Simulator, AVehicleWhoseDrivesAreAllDeadCoastsWhateverItsWheelsAreToldAndOneDeadDriveOnlySlowsIt) {
  const auto speed_after = [](int dead_drives) {
    SimulatorOptions options;
    for (int i = 0; i < dead_drives; ++i) options.faults.push_back({i, 0.0, ModuleFault::kDeadDrive, false});
    Simulator simulator(testing::make_params(4), options);
    Eigen::VectorXd start = Eigen::VectorXd::Zero(10);
    start[StateIndex::kVx] = 1.0;
    simulator.reset(start);
    ModuleArray<ModuleCommand> commands(4);
    for (int i = 0; i < 4; ++i) commands[i].wheel_speed = 2.0 / simulator.model().params().layout.wheel_radius();
    for (int k = 0; k < 10; ++k) EXPECT_TRUE(simulator.advance(commands));
    return simulator.state()[StateIndex::kVx];
  };
  EXPECT_NEAR(speed_after(4), 1.0, 1e-9);  // no drive, no rolling resistance: momentum alone
  const double healthy = speed_after(0), one_dead = speed_after(1);
  EXPECT_GT(healthy, 1.3);
  EXPECT_GT(one_dead, 1.2);
  EXPECT_LT(one_dead, healthy);
}

TEST(Simulator, AFaultOnAModuleTheVehicleDoesNotHaveIsRefusedNamingIt) {
  SimulatorOptions options;
  options.faults.push_back({4, 1.0, ModuleFault::kStuckSteering, false});
  const std::string message = testing::config_error_of([&] { Simulator(ideal_plant_params(), options); });
  EXPECT_NE(message.find("faults[0].module = 4"), std::string::npos) << message;
  options.faults[0] = {0, -1.0, ModuleFault::kStuckSteering, false};
  EXPECT_NE(testing::config_error_of([&] { options.validate(); }).find("faults[0].at = -1"), std::string::npos);
  options.faults[0] = {0, 1.0, ModuleFault::kNone, false};
  EXPECT_NE(testing::config_error_of([&] { options.validate(); }).find("faults[0].kind = none"), std::string::npos);
}

TEST(Simulator, AModuleOnAFrictionPatchGetsThePatchsGripAndTheOthersKeepTheTires) {
  // A 4-module vehicle at rest at the origin: the patch covers x >= 0, so the front modules
  // (x > 0) stand on mu 0.4 and the rear ones on the tire's 0.8.
  const VehicleParams params = testing::make_params(4);
  SimulatorOptions options;
  options.friction_patches.push_back({Eigen::Vector2d(0.0, -5.0), Eigen::Vector2d(5.0, 5.0), 0.4});
  Simulator simulator(params, options);
  simulator.reset(Eigen::VectorXd::Zero(10));
  double expected_mean = 0.0, total = 0.0;
  for (int i = 0; i < 4; ++i) {
    const bool front = params.layout.position_body(i).x() > 0.0;
    EXPECT_DOUBLE_EQ(simulator.friction_scales()[static_cast<std::size_t>(i)], front ? 0.5 : 1.0) << "module " << i;
    expected_mean += simulator.model().static_normal_loads()[static_cast<std::size_t>(i)] * (front ? 0.5 : 1.0);
    total += simulator.model().static_normal_loads()[static_cast<std::size_t>(i)];
  }
  EXPECT_NEAR(simulator.mean_friction_scale(), expected_mean / total, 1e-12);
  // The same sideways push: a module on the patch slips further under its half grip, so the plant
  // that drives over it moves differently from one on the dry floor.
  Simulator dry(params, SimulatorOptions{});
  Eigen::VectorXd sliding = Eigen::VectorXd::Zero(10);
  sliding[StateIndex::kVx] = 1.0;
  sliding[StateIndex::kVy] = 0.05;
  simulator.reset(sliding);
  dry.reset(sliding);
  for (int i = 0; i < 4; ++i) {
    const double ratio = simulator.module_samples()[static_cast<std::size_t>(i)].fy_wheel /
                         dry.module_samples()[static_cast<std::size_t>(i)].fy_wheel;
    EXPECT_NEAR(ratio, params.layout.position_body(i).x() > 0.0 ? 0.5 : 1.0, 1e-12) << "module " << i;
  }
}

TEST(SimulatorOptions, FrictionPatchesWithNoGripReversedCornersOrOverlapsAreRefusedNamingThem) {
  SimulatorOptions options;
  options.friction_patches.push_back({Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(10.0, 10.0), 0.0});
  EXPECT_NE(testing::config_error_of([&] { options.validate(); }).find("friction_patches[0].mu = 0"), std::string::npos);
  options.friction_patches[0] = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(10.0, -1.0), 0.4};
  const std::string corners = testing::config_error_of([&] { options.validate(); });
  EXPECT_NE(corners.find("friction_patches[0].max = [10, -1]"), std::string::npos) << corners;
  options.friction_patches[0] = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(10.0, 10.0), 0.4};
  options.friction_patches.push_back({Eigen::Vector2d(10.0, 0.0), Eigen::Vector2d(20.0, 10.0), 0.6});
  EXPECT_NO_THROW(options.validate());  // touching is not overlapping
  SimulatorOptions too_grippy;
  too_grippy.friction_patches.push_back({Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(1.0, 1.0), 9.0});
  const std::string grippy = testing::config_error_of([&] { Simulator(testing::make_params(4), too_grippy); });
  EXPECT_NE(grippy.find("friction_patches[0].mu = 9: must be at most 10x the tire's mu"), std::string::npos) << grippy;
  options.friction_patches.push_back({Eigen::Vector2d(19.0, 9.0), Eigen::Vector2d(30.0, 30.0), 0.6});
  const std::string overlap = testing::config_error_of([&] { options.validate(); });
  EXPECT_NE(overlap.find("friction_patches[2] = [19, 9] to [30, 30]: overlaps friction_patches[1]"), std::string::npos)
      << overlap;
}

}  // namespace
}  // namespace swerve
