// Loads a `scenario:` section (configs/scenarios/*.yaml): the vehicle, the reference trajectory,
// the run's duration and initial state, the simulated plant's options, and the controllers to
// compare on the same plant, seed and reference. Files named inside are relative to the scenario.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/config_node.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/sim/simulator.hpp"

namespace swerve {

// Longest run a scenario may ask for, in control periods. Each period keeps a log record (about
// 1.5 kB for 16 modules), so 100000 periods (83 min of simulated time at 50 ms) stay near 150 MB;
// without a bound, duration: 1e9 overflowed the step count and 1e7 ran out of memory mid-run.
inline constexpr int kMaxScenarioSteps = 100000;

struct ScenarioController {
  std::string name;         // e.g. wear_mpc, dynamic_no_wear, kinematic_baseline
  std::string config_file;  // resolved path
  ControllerConfig config;  // with the scenario's overrides applied
};

struct ScenarioConfig {
  std::string file;
  std::string name, description;
  std::string vehicle_file;
  VehicleParams vehicle;
  std::shared_ptr<const Reference> reference;
  std::string reference_description;  // e.g. "sine A=2 m, lambda=20 m, 40 m at 1 m/s, heading offset 0 deg"
  double duration = 0.0;              // s of simulated time
  Eigen::VectorXd initial_state;      // pose, twist, steering angles (6 + n)
  SimulatorOptions simulator;
  std::vector<ScenarioController> controllers;
  std::optional<double> paper_wear_reduction_pct;  // the paper's figure, where it has one

  explicit ScenarioConfig(VehicleParams v) : vehicle(std::move(v)) {}

  // Control periods in the run: ceil(duration / simulator.control_period). Throws ConfigError
  // when that is not a number in [1, kMaxScenarioSteps] (the loader rejects such files first).
  int steps() const;
};

// Keys (defaults in brackets; SI units, radians):
//   name, description [""], vehicle (file), duration [the reference's duration]
//     (at most kMaxScenarioSteps control periods)
//   reference: {type: line | arc | sine | figure_eight | csv, speed [1], acceleration [0],
//     stop_at_end [false], heading_offset [0]; line: start [[0,0]], direction [0], length;
//     arc: start [[0,0]], direction [0], radius, sweep; sine: amplitude, wavelength, length;
//     figure_eight: size, loops [1]; csv: file, laps [1] (the path driven again from its end)}
//   initial_state [the reference's start pose, at rest, steering 0]: {pose [ref start], twist [[0,0,0]],
//     steering [0] (one angle for all modules, or one per module)}
//   simulator: {substeps [0: automatic], seed [1], measurement_delay_steps [0],
//     noise: {position, heading, velocity, yaw_rate, steering_angle} [0],
//     initial_module_wear [none: new tires] (one entry per module, >= 0, wear units)}
//   controllers: [{name, config (file), wear_weight [from file], backend [from file],
//     friction_estimation, wear_balancing [from file]}]  (>= 1)
//   measurement_filter [each controller's own]: {pose_gain [1], steering_gain [1]}, for every controller alike
//   paper: {wear_reduction_pct}  [absent]
// The plant's control period is the first controller's dt; every controller must share it.
// After loading, the plant and every controller are built once and dropped, so that a file that
// loads (and passes `check-config`) is one that `run` accepts: constructor-only rules count too.
ScenarioConfig load_scenario_config(const config::ConfigNode& scenario_node);
ScenarioConfig load_scenario_config_file(const std::string& file_path);

}  // namespace swerve
