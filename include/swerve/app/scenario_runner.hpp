// Runs a scenario: each of its controllers closes the loop on its own copy of the same simulated
// plant, from the same initial state, with the same seed and reference; keeps a per-step log and
// computes the run's metrics.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "swerve/app/scenario_config.hpp"
#include "swerve/sim/metrics.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

struct ControllerRun {
  std::string name;
  ControllerKind kind = ControllerKind::kWearMpc;
  std::string backend;          // "" for the baseline
  double wear_weight = 0.0;     // lambda as configured (0 for the baseline)
  double effective_wear_weight = 0.0;  // the lambda the cost used on this vehicle (reference-mass scaling)
  double solve_budget = 0.0;    // s
  std::vector<StepRecord> log;
  RunMetrics metrics;
  // The module faults the controller knew of at the end (set or found), and what the vehicle could
  // then no longer do without dragging a tire (describe_lost_motions; "" without faults).
  ModuleFaults module_faults;
  std::string lost_motions;
  bool completed = false;       // false: the plant diverged; `failure` says when
  std::string failure;
};

// An override that does not fit the scenario (an unknown or repeated controller name, an unbuilt
// backend): the request is wrong, not the file. The CLI reports it as a command-line error.
class OverrideError : public ConfigError {
 public:
  using ConfigError::ConfigError;
};

struct RunOverrides {
  std::vector<std::string> controllers;  // run only these, once each (empty: all); unknown names are errors
  std::optional<std::uint64_t> seed;     // the simulator's seed
  std::optional<std::string> backend;    // every wear_mpc controller's backend
  std::optional<double> wear_weight;     // every wear_mpc controller's lambda (sweeps)
  std::optional<TrackingTolerance> tracking_tolerance;  // every wear_mpc controller's tube (sweeps)
};

// Called after every control period with (controller index, steps done, steps in the run).
using ProgressCallback = std::function<void(std::size_t, int, int)>;

// Applies the overrides to a copy of the scenario (OverrideError for unknown or repeated names and
// unbuilt backends).
ScenarioConfig apply_overrides(const ScenarioConfig& scenario, const RunOverrides& overrides);

// Runs one controller of the scenario on the plant. `clock`: what the controller's deadline is kept
// on (nullptr: the steady clock); a clock that advances by the work done makes a run repeatable
// bit for bit, whatever the machine's load.
ControllerRun run_controller(const ScenarioConfig& scenario, const ScenarioController& controller,
                             const ProgressCallback& progress = {}, std::size_t index = 0,
                             const Clock* clock = nullptr);

// Runs every controller of the scenario, in order.
std::vector<ControllerRun> run_scenario(const ScenarioConfig& scenario, const ProgressCallback& progress = {},
                                        const Clock* clock = nullptr);

}  // namespace swerve
