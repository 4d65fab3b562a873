#include "swerve/app/scenario_runner.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {
namespace {

// Each tire's wear before the run plus the plant's so far.
Eigen::VectorXd lifetime_wear(const SimulatorOptions& options, const Simulator& plant) {
  Eigen::VectorXd wear = Eigen::Map<const Eigen::VectorXd>(plant.module_wear().data(),
                                                           static_cast<Eigen::Index>(plant.module_wear().size()));
  if (!options.initial_module_wear.empty()) {
    wear += Eigen::Map<const Eigen::VectorXd>(options.initial_module_wear.data(), wear.size());
  }
  return wear;
}

std::uint32_t fault_mask(const ModuleFaults& faults) {
  std::uint32_t mask = 0;
  for (int i = 0; i < faults.size(); ++i) {
    if (faults[i] != ModuleFault::kNone) mask |= 1u << i;
  }
  return mask;
}

// How far a wear-aware controller's prediction model, at the grip and with the faults it used, misses the plant over
// one period: from the plant's true state (its actuator states included) under the commands sent,
// the position and the wear one period on against the plant's. What a wrong grip costs shows here
// before it shows in the tracking.
class PredictionAudit {
 public:
  // `faults`: the module faults the controller knows (its prediction's), observed; must outlive this.
  PredictionAudit(const VehicleParams& vehicle, const PredictionOptions& options, const ModuleFaults* faults)
      : model_(vehicle, options), data_(model_.create_data()), scales_(static_cast<std::size_t>(kMaxModules), 1.0) {
    model_.observe_friction_scales(scales_.data());
    model_.observe_module_faults(faults);
    state_ = Eigen::VectorXd::Zero(model_.state_size());
    next_ = state_;
    inputs_ = Eigen::VectorXd::Zero(model_.input_size());
  }
  // Before the plant advances under `commands`, at the grip `scale` the controller used.
  void predict(const Simulator& plant, const ModuleArray<ModuleCommand>& commands, double scale, double period) {
    const int n = plant.modules();
    const VehicleModel<double>& truth = plant.model();
    state_.head(StateIndex::prefix_size(n)) = plant.state().head(StateIndex::prefix_size(n));
    for (int i = 0; i < n; ++i) {
      const int first = StateIndex::prefix_size(n);
      const int wheel = truth.wheel_speed_index(i), rate = truth.steering_rate_index(i);
      if (model_.wheel_speed_states() > 0) state_[first + i] = wheel >= 0 ? plant.state()[wheel] : commands[i].wheel_speed;
      if (model_.steering_rate_states() > 0) {
        state_[first + model_.wheel_speed_states() + i] = rate >= 0 ? plant.state()[rate] : commands[i].steering_rate;
      }
      inputs_[InputIndex::steering_rate(i)] = commands[i].steering_rate;
      inputs_[InputIndex::wheel_speed(i)] = commands[i].wheel_speed;
    }
    std::fill(scales_.begin(), scales_.end(), scale);
    wear_before_ = total_wear(plant);
    predicted_ = model_.step(*data_, state_, inputs_, period, next_, &predicted_wear_);
  }
  // After it advanced: the errors into `record` (left NaN when the prediction failed).
  void judge(const Simulator& plant, StepRecord* record) const {
    if (!predicted_) return;
    record->prediction_position_error_m = (next_.head<2>() - plant.state().head<2>()).norm();
    record->prediction_wear_error = predicted_wear_ - (total_wear(plant) - wear_before_);
  }

 private:
  static double total_wear(const Simulator& plant) {
    double sum = 0.0;
    for (double w : plant.module_wear()) sum += w;
    return sum;
  }
  VehiclePredictionModel model_;
  std::unique_ptr<PredictionData> data_;
  std::vector<double> scales_;
  Eigen::VectorXd state_, next_, inputs_;
  double predicted_wear_ = 0.0, wear_before_ = 0.0;
  bool predicted_ = false;
};

}  // namespace

ScenarioConfig apply_overrides(const ScenarioConfig& scenario, const RunOverrides& overrides) {
  ScenarioConfig s = scenario;
  if (!overrides.controllers.empty()) {
    std::vector<ScenarioController> chosen;
    for (const std::string& name : overrides.controllers) {
      // A repeated name would run the controller twice, but summary.json keys runs by name.
      if (std::any_of(chosen.begin(), chosen.end(), [&](const ScenarioController& c) { return c.name == name; })) {
        throw OverrideError("--controllers: '" + printable_value(name) + "' is given twice");
      }
      const auto it = std::find_if(s.controllers.begin(), s.controllers.end(),
                                   [&](const ScenarioController& c) { return c.name == name; });
      if (it == s.controllers.end()) {
        std::string known;
        for (const ScenarioController& c : s.controllers) known += (known.empty() ? "" : ", ") + c.name;
        throw OverrideError(printable_value(scenario.file, std::string::npos) + ": --controllers: '" +
                            printable_value(name) + "' is not a controller of this scenario (" + known + ")");
      }
      chosen.push_back(*it);
    }
    s.controllers = std::move(chosen);
  }
  if (overrides.seed) s.simulator.seed = *overrides.seed;
  if (overrides.backend) {  // checked even when no controller would use it: a typo must not pass
    SolverConfig probe;
    probe.backend = *overrides.backend;
    try {
      probe.validate();
    } catch (const ConfigError& error) {
      throw OverrideError(std::string("--backend: ") + error.what());
    }
  }
  if (overrides.tracking_tolerance) {  // checked even when no controller would use it, as --backend
    try {
      overrides.tracking_tolerance->validate();
    } catch (const ConfigError& error) {
      throw OverrideError(std::string("--tolerance: ") + error.what());
    }
  }
  for (ScenarioController& c : s.controllers) {
    if (c.config.kind != ControllerKind::kWearMpc) continue;
    if (overrides.backend) c.config.solver.backend = *overrides.backend;
    // A sweep moves the wear-aware controllers' lambda, never a configured lambda = 0 comparison.
    if (overrides.wear_weight && c.config.mpc.wear_weight > 0.0) c.config.mpc.wear_weight = *overrides.wear_weight;
    if (overrides.tracking_tolerance) c.config.mpc.tracking_tolerance = *overrides.tracking_tolerance;
  }
  return s;
}

ControllerRun run_controller(const ScenarioConfig& scenario, const ScenarioController& controller,
                             const ProgressCallback& progress, std::size_t index, const Clock* clock) {
  ControllerRun run;
  run.name = controller.name;
  run.kind = controller.config.kind;
  const bool mpc = run.kind == ControllerKind::kWearMpc;
  run.backend = mpc ? controller.config.solver.backend : "";
  run.wear_weight = mpc ? controller.config.mpc.wear_weight : 0.0;
  run.effective_wear_weight = mpc ? controller.config.mpc.effective_wear_weight(scenario.vehicle.mass) : 0.0;
  run.solve_budget = controller.config.solve_budget();

  std::unique_ptr<TrackingController> tracker =
      make_controller(controller.config, scenario.vehicle, scenario.reference);
  if (clock != nullptr) tracker->set_clock(*clock);
  Simulator plant(scenario.vehicle, scenario.simulator);
  plant.reset(scenario.initial_state);
  const double period = scenario.simulator.control_period;
  const int steps = scenario.steps();
  const int n = plant.modules();
  run.log.reserve(static_cast<std::size_t>(steps));
  std::optional<PredictionAudit> audit;
  if (mpc) audit.emplace(scenario.vehicle, controller.config.mpc.prediction, &tracker->module_faults());
  for (int k = 0; k < steps; ++k) {
    const double t = k * period;
    // A fault the vehicle's own diagnostics report reaches the controller as it begins.
    for (const PlantFault& fault : scenario.simulator.faults) {
      if (fault.announced && fault.due_by(t) && tracker->module_faults()[fault.module] != fault.kind) {
        tracker->set_module_fault(fault.module, fault.kind);
      }
    }
    // A map of the floor tells the controller the grip under the vehicle.
    if (scenario.simulator.announce_friction) tracker->set_friction_scale(plant.mean_friction_scale());
    // Each tire's wear so far, as a fleet's maintenance log (or a tread sensor) would give it.
    tracker->set_module_wear(lifetime_wear(scenario.simulator, plant));
    // The measurement carries its timestamp, so a delayed one is known to be old.
    const ControlOutput& output = tracker->step(plant.measurement(), t, t - plant.measurement_age());
    StepRecord record;
    record.t = t;
    record.pose_world = plant.state().head<3>();
    record.twist_body = plant.state().segment<3>(StateIndex::kVx);
    // Judged against the reference where the controller's clock has it (a held start is late, not off).
    record.reference_delay_s = output.reference_delay_s;
    record.reference_pose_world = scenario.reference->sample(t - output.reference_delay_s).pose_world;
    record.modules = plant.module_samples();
    record.commands.assign(output.modules.begin(), output.modules.begin() + n);
    record.source = output.source;
    record.solve_status = output.solve.status;
    record.solve_time_s = output.solve.status == SolveStatus::kNotRun ? -1.0 : output.solve.solve_time_s;
    record.solve_iterations = output.solve.iterations;
    record.plan_cost = output.solve.cost;
    record.initial_guess_cost = output.solve.initial_cost;
    record.step_time_s = output.step_time_s;
    record.solve_late_s = output.solve.status == SolveStatus::kNotRun ? 0.0 : output.solve.late_s;
    record.work_budget_cut = output.work_budget_cut;
    record.known_faults = fault_mask(tracker->module_faults());
    record.friction_scale = plant.mean_friction_scale();
    record.friction_scale_used = output.friction_scale;
    run.log.push_back(std::move(record));
    // While the commands act, the next step's preparation (rti; a no-op for the other backends),
    // outside that step's time, as a vehicle's loop would run it after sending its commands.
    tracker->prepare(t + period);
    if (audit) audit->predict(plant, output.modules, output.friction_scale, period);
    const bool advanced = plant.advance(output.modules);
    if (audit && advanced) audit->judge(plant, &run.log.back());
    // The faults the plant had over this period (one starting at t acts from t on).
    run.log.back().plant_faults = fault_mask(plant.active_faults());
    if (!advanced) {
      run.failure = "the plant diverged at t = " + std::to_string(plant.time()) + " s";
      break;
    }
    if (progress) progress(index, k + 1, steps);
  }
  run.module_faults = tracker->module_faults();
  ModuleArray<double> angles(n, 0.0);
  for (int i = 0; i < n; ++i) angles[i] = plant.state()[StateIndex::steering(i)];
  run.lost_motions = describe_lost_motions(scenario.vehicle.layout, run.module_faults, angles);
  run.completed = run.failure.empty();
  run.metrics = compute_metrics(run.log, plant.module_wear(), plant.frictional_energy(), period, run.solve_budget);
  run.metrics.lifetime_wear_imbalance = wear_imbalance(lifetime_wear(scenario.simulator, plant));
  return run;
}

std::vector<ControllerRun> run_scenario(const ScenarioConfig& scenario, const ProgressCallback& progress,
                                        const Clock* clock) {
  std::vector<ControllerRun> runs;
  for (std::size_t i = 0; i < scenario.controllers.size(); ++i) {
    runs.push_back(run_controller(scenario, scenario.controllers[i], progress, i, clock));
  }
  return runs;
}

}  // namespace swerve
