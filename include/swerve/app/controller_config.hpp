// Loads a `controller:` section (configs/controllers/*.yaml): which controller (the wear-aware MPC
// or the kinematic baseline), its horizon, step, weights, deadline, prediction model, solver
// backend and the baseline's own tuning; and builds the controller it describes.
#pragma once

#include <memory>
#include <string>

#include "swerve/app/config_node.hpp"
#include "swerve/control/controller.hpp"
#include "swerve/control/kinematic_baseline.hpp"
#include "swerve/solvers/solver_config.hpp"

namespace swerve {

enum class ControllerKind { kWearMpc, kKinematicBaseline };
const char* to_string(ControllerKind kind) noexcept;  // "wear_mpc", "kinematic_baseline"

struct ControllerConfig {
  std::string name;  // label in reports; the scenario's name for it wins
  ControllerKind kind = ControllerKind::kWearMpc;
  ControllerOptions mpc;       // wear_mpc only
  SolverConfig solver;         // wear_mpc only
  BaselineOptions baseline;    // the baseline controller, and the wear_mpc's initial-guess planner
  double solve_budget() const { return kind == ControllerKind::kWearMpc ? mpc.solve_budget : baseline.dt; }
  double dt() const { return kind == ControllerKind::kWearMpc ? mpc.dt : baseline.dt; }
  // s between steps: the wear_mpc's control_period (its dt when 0), the baseline's dt.
  double period() const { return kind == ControllerKind::kWearMpc ? mpc.period() : baseline.dt; }
  // The observer in front of either controller (and of the wear_mpc's initial-guess planner).
  void set_measurement_filter(const MeasurementFilterOptions& filter);
  // Horizon N and step dt (s) of both the wear-aware controller and the baseline (its own, or the
  // wear-aware controller's initial-guess planner): the controller is stepped every dt.
  void set_sampling(int horizon, double dt);
  void validate() const;       // throws ConfigError naming the field and value
};

// Keys (defaults in brackets; SI units):
//   name, description [""], type (wear_mpc | kinematic_baseline), horizon [20], dt [0.05]
//   wear_mpc only:
//     control_period [dt] (s between steps; at most dt), solve_budget [0.02], overrun_grace [0.002], deadline_margin [0.05], baseline_guess [true], max_plan_age [5],
//     inputs [body_twist] (body_twist | module_rates: what the optimiser searches, see ControllerOptions)
//     weights: {pose [10,10,5], twist [0,0,0], terminal_scale [10], step [0] (the dt they are set for; ControllerOptions::weights_step),
//               pose_huber_width [0], wear [1], steering_rate_effort [0.01],
//               wheel_speed_effort [0], steering_rate_smoothness [0.05], wheel_speed_smoothness [0.01],
//               twist_smoothness [1] (body_twist inputs; the effort/smoothness keys above are for module_rates)}
//     prediction: {method [semi_implicit] (semi_implicit | rk4), substeps [1], slow_substeps [5],
//                   max_newton_iterations [8]}
//     solver: {backend [sa], sa: {knots, max_iterations, initial_acceptance, final_temperature_ratio,
//              step_fraction, target_acceptance, adapt_interval, reheat_interval,
//              probability_one_group, probability_one_knot, seed, polish_share [0], polish_iterations [30],
//              knot_polish [false], threads [1]},
//              nlopt: {algorithm [LN_BOBYQA], xtol_rel [1e-8], ftol_rel [1e-12], max_evaluations [200000],
//                      initial_step_fraction [0.1]}}
//   baseline [defaults of BaselineOptions]: {pose_weight, twist_weight, rate_weight, terminal_scale,
//              gauss_newton_iterations, cosine_scaling, flip_hysteresis, steer_speed_threshold}
//   measurement_filter [off]: {pose_gain [1], steering_gain [1]} (either type; MeasurementFilterOptions)
ControllerConfig load_controller_config(const config::ConfigNode& controller_node);
// A `measurement_filter:` section over `defaults` (also the scenario-wide one).
MeasurementFilterOptions load_measurement_filter(const config::ConfigNode& node, MeasurementFilterOptions defaults);
ControllerConfig load_controller_config_file(const std::string& file_path);

// Builds the controller a config describes, tracking `reference` on `vehicle`, its optimiser built
// by `solvers`: make_core_solver (sa, rti; SwerveMPC::controllers alone), make_solver (every built
// backend; SwerveMPC::solvers) or a program's own. Throws ConfigError.
std::unique_ptr<TrackingController> make_controller(const ControllerConfig& config, const VehicleParams& vehicle,
                                                    std::shared_ptr<const Reference> reference,
                                                    const BackendFactory& solvers);

// One call for a vehicle program: the vehicle file's `vehicle:` section and the controller file's
// `controller:` section (the backend the file names), tracking `reference` (e.g. a
// TrajectoryReference its planner feeds). Throws ConfigError naming the file, key and value.
std::unique_ptr<TrackingController> make_controller(const std::string& vehicle_yaml, const std::string& controller_yaml,
                                                    std::shared_ptr<const Reference> reference,
                                                    const BackendFactory& solvers);

// The same with every built backend (make_solver): defined in SwerveMPC::scenarios, which links
// them all.
std::unique_ptr<TrackingController> make_controller(const ControllerConfig& config, const VehicleParams& vehicle,
                                                    std::shared_ptr<const Reference> reference);
std::unique_ptr<TrackingController> make_controller(const std::string& vehicle_yaml, const std::string& controller_yaml,
                                                    std::shared_ptr<const Reference> reference);

}  // namespace swerve
