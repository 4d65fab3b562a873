#include "swerve/sim/tuning.hpp"

#include <algorithm>

#include "swerve/sim/metrics.hpp"
#include "swerve/sim/simulator.hpp"

namespace swerve {

void TuningOptions::validate() const {
  if (horizons.empty()) throw ConfigError("TuningOptions.horizons: empty: give at least one horizon");
  for (const int n : horizons) {
    if (n < 1 || n > 1000) throw_invalid_field("TuningOptions", "horizons[]", n, "must be in [1, 1000]");
  }
  if (cycles < 1) throw_invalid_field("TuningOptions", "cycles", cycles, "must be >= 1");
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
  SpeedProfile profile;
  profile.speed = 0.5 * vehicle.layout.limits().max_drive_speed;

  const auto reference = std::make_shared<PathReference>(make_line_curve({0.0, 0.0}, 0.0, 1000.0), profile, 0.0);
  const double budget_here = target.solve_budget / target.cpu_slowdown;

  TuningResult result;
  for (const int horizon : options.horizons) {
    ControllerConfig config = controller;
    config.mpc.horizon = config.baseline.horizon = horizon;
    config.mpc.dt = config.baseline.dt = target.control_period;
    config.mpc.solve_budget = budget_here;
    std::unique_ptr<TrackingController> tracker = make_controller(config, vehicle, reference);
    SimulatorOptions sim;
    sim.control_period = target.control_period;
    Simulator plant(vehicle, sim);
    Eigen::VectorXd cruising = Eigen::VectorXd::Zero(6 + vehicle.layout.size());
    cruising[StateIndex::kVx] = profile.speed;  // already on the line at its speed: the common case
    plant.reset(cruising);
    std::vector<double> proposals, solve_ms;
    HorizonMeasurement row;
    for (int k = 0; k < options.cycles; ++k) {
      const ControlOutput& out = tracker->step(plant.measurement(), k * target.control_period);
      if (out.solve.status != SolveStatus::kNotRun) {
        proposals.push_back(std::max(0, out.solve.iterations));
        solve_ms.push_back(1e3 * out.solve.solve_time_s);
      }
      if (out.source != CommandSource::kOptimizer) ++row.fallbacks;
      if (!plant.advance(out.modules)) break;
    }
    row.horizon = horizon;
    row.lookahead_s = horizon * target.control_period;
    row.budget_here_ms = 1e3 * budget_here;
    row.proposals_median = percentile(proposals, 50.0);
    row.solve_p99_ms = percentile(solve_ms, 99.0);
    row.target_p99_ms = row.solve_p99_ms * target.cpu_slowdown;
    // A late solve is a fallback (the controller's own rule), so "no fallback" covers the deadline.
    row.qualifies = row.proposals_median >= options.min_proposals && row.fallbacks == 0;
    if (row.qualifies) result.recommended_horizon = std::max(result.recommended_horizon, horizon);
    result.rows.push_back(row);
  }
  return result;
}

}  // namespace swerve
