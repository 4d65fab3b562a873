#include "swerve/app/tuning.hpp"

#include <algorithm>

#include "swerve/app/scenario_runner.hpp"

namespace swerve {

void TuningOptions::validate() const {
  if (horizons.empty()) throw ConfigError("TuningOptions.horizons: empty: give at least one horizon");
  for (const int n : horizons) {
    if (n < 1 || n > kMaxHorizon) {
      throw_invalid_field("TuningOptions", "horizons[]", n, "must be in [1, " + std::to_string(kMaxHorizon) + "]");
    }
  }
  if (cycles < 1 || cycles > kMaxScenarioSteps) {
    throw_invalid_field("TuningOptions", "cycles", cycles, "must be in [1, " + std::to_string(kMaxScenarioSteps) + "]");
  }
  if (min_proposals < 1) throw_invalid_field("TuningOptions", "min_proposals", min_proposals, "must be >= 1");
}

TuningResult tune_horizon(const VehicleParams& vehicle, const ControllerConfig& controller, const TargetConfig& target,
                          const TuningOptions& options) {
  options.validate();
  target.validate();
  if (controller.kind != ControllerKind::kWearMpc) {
    throw ConfigError("tune: controller '" + controller.name + "' is a " + to_string(controller.kind) +
                      "; tuning sizes the wear_mpc controller");
  }
  // One scenario per horizon: on a straight line at half the drive speed limit, already moving at
  // that speed (the common case), run through the same closed loop as `swerve-mpc run`.
  SpeedProfile profile;
  profile.speed = 0.5 * vehicle.layout.limits().max_drive_speed;
  ScenarioConfig scenario(vehicle);
  scenario.name = "tune";
  scenario.reference = std::make_shared<PathReference>(make_line_curve({0.0, 0.0}, 0.0, 1000.0), profile, 0.0);
  scenario.duration = options.cycles * target.control_period;
  scenario.initial_state = Eigen::VectorXd::Zero(6 + vehicle.layout.size());
  scenario.initial_state[StateIndex::kVx] = profile.speed;
  scenario.simulator.control_period = target.control_period;
  const double budget_here = target.solve_budget / target.cpu_slowdown;

  TuningResult result;
  for (const int horizon : options.horizons) {
    ScenarioController entry{controller.name, "", controller};
    entry.config.mpc.horizon = entry.config.baseline.horizon = horizon;
    entry.config.mpc.dt = entry.config.baseline.dt = target.control_period;
    entry.config.mpc.solve_budget = budget_here;
    const ControllerRun run = run_controller(scenario, entry, {}, 0, options.clock);
    std::vector<double> proposals;
    for (const StepRecord& record : run.log) {
      if (record.solve_time_s >= 0.0) proposals.push_back(std::max(0, record.solve_iterations));
    }
    HorizonMeasurement row;
    row.horizon = horizon;
    row.lookahead_s = horizon * target.control_period;
    row.budget_here_ms = 1e3 * budget_here;
    row.proposals_median = percentile(proposals, 50.0);
    row.solve_p99_ms = run.metrics.solve_time_p99_ms;
    row.target_p99_ms = row.solve_p99_ms * target.cpu_slowdown;
    row.fallbacks = run.metrics.fallbacks;
    // A late solve is a fallback (the controller's own rule), so "no fallback" covers the deadline.
    row.qualifies = run.completed && row.proposals_median >= options.min_proposals && row.fallbacks == 0;
    if (row.qualifies) result.recommended_horizon = std::max(result.recommended_horizon, horizon);
    result.rows.push_back(row);
  }
  return result;
}

}  // namespace swerve
