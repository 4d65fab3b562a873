// What one closed-loop run is judged by: tracking error against the reference, tire wear per module
// and in total, frictional energy, control effort, and the controller's solve times, deadline
// misses and fallbacks. Computed from the per-step log that the scenario runner keeps.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <vector>

#include "swerve/control/tracking_controller.hpp"
#include "swerve/sim/simulator.hpp"

namespace swerve {

// One control period of a run, logged at its start (before the command is applied).
struct StepRecord {
  double t = 0.0;
  Eigen::Vector3d pose_world = Eigen::Vector3d::Zero();      // true plant pose (psi unwrapped)
  Eigen::Vector3d twist_body = Eigen::Vector3d::Zero();
  Eigen::Vector3d reference_pose_world = Eigen::Vector3d::Zero();  // at t - reference_delay_s
  double reference_delay_s = 0.0;                             // ControlOutput::reference_delay_s
  std::vector<PlantModuleSample> modules;                    // plant, at t
  std::vector<ModuleCommand> commands;                       // what the controller sent at t
  CommandSource source = CommandSource::kSafeStop;
  SolveStatus solve_status = SolveStatus::kNotRun;
  double solve_time_s = 0.0;                                  // < 0 when no solve ran
  double step_time_s = -1.0;                                  // the whole controller step; < 0 unknown
  double solve_late_s = 0.0;                                  // how far past its deadline the solver returned
  bool work_budget_cut = false;                               // ControlOutput::work_budget_cut
  int solve_iterations = -1;
  // Module faults as bit masks (bit i: module i): the plant's over the period from t, and those
  // the controller knew of (set or found) after its step at t.
  std::uint32_t plant_faults = 0, known_faults = 0;
  // The floor's grip under the vehicle at t (Simulator::mean_friction_scale) and the one the
  // controller's prediction used (ControlOutput::friction_scale), as multiples of the tire's mu.
  double friction_scale = 1.0, friction_scale_used = 1.0;
  // A wear-aware controller's prediction model at the grip it used, one period on from the plant's
  // true state under the commands sent, against the plant: the position missed (m) and the wear
  // predicted less the wear that happened (wear units). NaN where no model predicted.
  double prediction_position_error_m = std::numeric_limits<double>::quiet_NaN();
  double prediction_wear_error = std::numeric_limits<double>::quiet_NaN();
  // The optimiser's own view of the step: the predicted cost of the plan it returned, by part, and
  // of the best initial guess it started from (< 0 when no solve ran or the solver reports none).
  CostBreakdown plan_cost;
  double initial_guess_cost = -1.0;
  // Whether an optimiser ran and reported the costs above (the kinematic baseline's least-squares
  // solve has no such cost and reports no guess).
  bool has_plan_cost() const { return solve_time_s >= 0.0 && initial_guess_cost >= 0.0; }

  double position_error() const { return (pose_world.head<2>() - reference_pose_world.head<2>()).norm(); }
  double heading_error() const;  // wrapped, rad
};

struct RunMetrics {
  int steps = 0;
  double tracking_rmse_m = 0.0, tracking_max_m = 0.0;
  double heading_rmse_rad = 0.0, heading_max_rad = 0.0;
  std::vector<double> wear_per_module;
  double wear_total = 0.0;
  double wear_imbalance = 0.0;     // max / mean over modules (1: perfectly even)
  // The same of each tire's wear before the run (SimulatorOptions::initial_module_wear) plus the
  // run's: how evenly the tires are worn at its end (set by the scenario runner).
  double lifetime_wear_imbalance = 0.0;
  double frictional_energy_J = 0.0;
  double steering_effort = 0.0;    // integral of sum_i steering_rate_i^2 dt (rad^2/s)
  // RMS over periods and modules of the commanded steering rate's change per second (rad/s^2):
  // how hard the steering commands jerk from one period to the next (a chattering command shows
  // here even when its effort is small).
  double steering_command_jerk = 0.0;
  double solve_time_mean_ms = 0.0, solve_time_p50_ms = 0.0, solve_time_p99_ms = 0.0, solve_time_max_ms = 0.0;
  double step_time_p99_ms = 0.0, step_time_max_ms = 0.0;  // the whole step (plan, update, solve)
  int deadline_misses = 0;         // steps (or, where unknown, solves) that took longer than the budget
  // Solves that returned past their own deadline (SolveSummary::late_s > 0): a miss with none came
  // from outside the solver (the rest of the step, or a stall between the solve and the command).
  int late_solves = 0;
  // Steps whose work-budgeted solve the step's clock cut short (ControlOutput::work_budget_cut): 0
  // means the run's answers did not depend on the machine's speed.
  int work_budget_cuts = 0;
  int fallbacks = 0;               // periods whose command did not come from a successful solve
  int tracking_first_steps = 0;    // periods that sent the baseline's commands because the plan left the tube
  double reference_delay_s = 0.0;  // the controller's reference clock behind t at the end (ControlOutput)
  double solve_iterations_mean = 0.0;
  int safe_stops = 0;              // periods that sent a safe stop
  // Runs with plant faults (StepRecord::plant_faults): when the first began (s, -1: none), how many
  // control periods later the controller first knew of a module the plant had a fault on (-1:
  // never), and the position RMSE from that step on (-1: never known). false_fault_alarms: modules
  // the controller took as faulty while the plant had no fault there.
  double fault_onset_s = -1.0;
  int fault_detection_cycles = -1;
  double tracking_rmse_after_fault_known_m = -1.0;
  int false_fault_alarms = 0;
  // Runs whose floor changes grip (StepRecord::friction_scale): when the vehicle first touched a
  // new grip and when all of it stood on it (s, -1: no change), and how long after each the grip
  // the controller used came within 10 % of the floor's and stayed there while the floor held
  // (s, -1: never). The worst error once settled (%, -1: never settled).
  double friction_change_s = -1.0, friction_change_complete_s = -1.0;
  double friction_settle_after_change_s = -1.0, friction_settle_after_complete_s = -1.0;
  double friction_error_after_settle_max_pct = -1.0;
};

// Nearest-rank percentile (q in [0, 100]) of `values`; 0 for an empty list.
double percentile(std::vector<double> values, double q);

// `control_period` weights the effort integral; `solve_budget` (s) decides a deadline miss.
// max / mean of `wear_per_module` (1: perfectly even; 0 when there is no wear).
double wear_imbalance(const Eigen::Ref<const Eigen::VectorXd>& wear_per_module) noexcept;

// `wear_per_module` and `frictional_energy` are the simulator's integrals at the end of the run.
RunMetrics compute_metrics(const std::vector<StepRecord>& log, const std::vector<double>& wear_per_module,
                           double frictional_energy, double control_period, double solve_budget);

}  // namespace swerve
