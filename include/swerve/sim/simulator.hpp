// The plant the controllers are tested against: the vehicle model at plant fidelity (actuator lag
// and saturation, optional relaxation and load transfer) integrated with RK4 at a fine substep,
// while the controller runs at its own period; measurement noise and delay from a seeded generator,
// so identical seeds give identical runs. It also integrates each module's wear and the frictional
// energy dissipated in every contact.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <deque>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/models/integrators.hpp"
#include "swerve/models/vehicle_model.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

struct MeasurementNoise {
  double position = 0.0;        // m, standard deviation on x and y
  double heading = 0.0;         // rad
  double velocity = 0.0;        // m/s on vx, vy
  double yaw_rate = 0.0;        // rad/s
  double steering_angle = 0.0;  // rad
  // The rules of every field (each a standard deviation >= 0), for validate() and the loader.
  static const OptionFields<MeasurementNoise>& fields();
};

// A fault the plant develops during a run: from the first control period that starts at or after
// `at` (s), module `module` has `kind` (a stuck steering stops turning where it is; a dead drive's
// wheel rolls free, VehicleModel::observe_module_faults; a lost steering sensor measures NaN).
struct PlantFault {
  int module = 0;
  double at = 0.0;
  ModuleFault kind = ModuleFault::kStuckSteering;
  // Whether the controllers are told at onset (TrackingController::set_module_fault), as a
  // vehicle's own diagnostics would; false: they must find it themselves.
  bool announced = false;
  // Whether the period starting at `period_start` (s) has it: one starting within a microsecond
  // of `at` counts as starting at it.
  bool due_by(double period_start) const noexcept { return at <= period_start + 1e-6; }
};

// A stretch of floor with its own grip (a wet or dusty patch): an axis-aligned rectangle in the
// world frame where the tires' peak friction is `mu` instead of the vehicle's tire mu. A module
// whose contact point is inside it has it (VehicleModel::observe_friction_scales).
struct FrictionPatch {
  Eigen::Vector2d min_world = Eigen::Vector2d::Zero();  // m, the corner of least x and y
  Eigen::Vector2d max_world = Eigen::Vector2d::Zero();  // m, the corner of greatest x and y
  double mu = 0.4;
  bool contains(const Eigen::Vector2d& point_world) const noexcept {
    return (point_world.array() >= min_world.array()).all() && (point_world.array() <= max_world.array()).all();
  }
  // Whether max_world lies beyond min_world in both x and y (the patch has an area).
  bool corners_in_order() const noexcept { return (max_world.array() > min_world.array()).all(); }
  // Whether the two share an area (touching along an edge is not overlapping).
  bool overlaps(const FrictionPatch& other) const noexcept {
    return (min_world.array() < other.max_world.array()).all() && (other.min_world.array() < max_world.array()).all();
  }
};

struct SimulatorOptions {
  double control_period = 0.05;  // s between controller calls
  // Plant RK4 substeps per control period; 0 picks them from the tire-slip time constant of a wheel
  // at rest (VehicleModel::recommended_substeps), the stiffest case.
  int substeps = 0;
  MeasurementNoise noise;
  int measurement_delay_steps = 0;  // the controller sees the state this many periods old
  std::uint64_t seed = 1;
  std::vector<PlantFault> faults;   // none by default
  std::vector<FrictionPatch> friction_patches;  // none by default: the tire's mu everywhere
  // Whether the controllers are told the grip under the vehicle each period (TrackingController::
  // set_friction_scale with mean_friction_scale()), as a map of the floor would; false: a
  // controller that uses the grip must estimate it.
  bool announce_friction = false;
  // Each module's tire wear before the run (wear units; empty: new tires). The runner tells the
  // controllers each module's accumulated wear, this plus the run's, every period
  // (TrackingController::set_module_wear), and reports the spread of the sum.
  std::vector<double> initial_module_wear;
  // The rules of the fields a scenario's `simulator:` block sets (substeps, measurement_delay_steps),
  // one table for validate() and the loader. control_period is the controllers' (checked by
  // validate() alone), the seed any unsigned integer, the noise MeasurementNoise::fields().
  static const OptionFields<SimulatorOptions>& fields();
  // Throws ConfigError naming the field and value: also a patch with mu <= 0, corners not in
  // order, or two patches that overlap (which grip would hold there is not said), and an initial
  // wear that is negative or not finite. (Its size is the vehicle's to check: Simulator.)
  void validate() const;
};

// Per-module quantities of the plant at the start of a control period (for logs).
struct PlantModuleSample {
  double steering_angle = 0.0, wheel_speed = 0.0;  // rad, rad/s
  double slip_angle = 0.0, slip_ratio = 0.0;
  double fx_wheel = 0.0, fy_wheel = 0.0;          // N
  double wear_rate = 0.0;                         // wear units / s
  double wear = 0.0;                              // cumulative, wear units
};

class Simulator {
 public:
  // Throws ConfigError for invalid params or options, also a friction patch gripping more than 10x
  // the tire.
  Simulator(const VehicleParams& vehicle, SimulatorOptions options);
  // Its model observes its own members (the faults, the grip) and its integrator refers to the
  // model: built in place only.
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  // Starts a new run from `initial_prefix` (pose, twist, steering angles; size 6 + n), wheels
  // rolling without slip, time 0, wear and energy 0, the noise generator reseeded.
  void reset(const Eigen::VectorXd& initial_prefix);

  // The measurement the controller receives now (pose, twist, steering angles), noisy and delayed
  // as configured.
  const Eigen::VectorXd& measurement() const noexcept { return measurement_; }
  // How old measurement() is, in s: the configured delay once the run is that long (a sensor
  // stamps its data; controllers read the age from the timestamp t - measurement_age()).
  double measurement_age() const noexcept {
    return static_cast<double>(delayed_.empty() ? 0 : delayed_.size() - 1) * options_.control_period;
  }

  // Applies module commands (steering rate and wheel speed, through the plant's actuators) for one
  // control period. Returns false, leaving the state as it was, if the plant produced a non-finite
  // state (the run should stop and say so).
  bool advance(const ModuleArray<ModuleCommand>& commands) noexcept;

  double time() const noexcept { return time_; }
  const Eigen::VectorXd& state() const noexcept { return state_; }  // full plant state
  int modules() const noexcept { return model_.modules(); }
  int substeps() const noexcept { return substeps_; }
  const VehicleModel<double>& model() const noexcept { return model_; }
  const std::vector<double>& module_wear() const noexcept { return module_wear_; }
  double frictional_energy() const noexcept { return frictional_energy_; }  // J, all contacts
  // Per-module slips, forces and wear rate at the current state under the last command.
  const std::vector<PlantModuleSample>& module_samples() const noexcept { return samples_; }
  // The faults the plant has now (PlantFault): every module kNone before its fault's onset.
  const ModuleFaults& active_faults() const noexcept { return active_faults_; }
  // The floor's grip under each module now, as a multiple of the vehicle's tire mu (1 off every
  // friction patch).
  const std::vector<double>& friction_scales() const noexcept { return friction_scales_; }
  // The same, averaged over the modules with the static loads as weights: the single scale a
  // controller's prediction would take for the whole vehicle.
  double mean_friction_scale() const noexcept { return model_.load_weighted_friction_scale(); }

 private:
  void refresh_samples() noexcept;
  // Starts the faults due by the period starting now, and holds a stuck steering's rate at zero.
  void apply_faults() noexcept;
  void update_measurement() noexcept;
  // friction_scales_ for the contact points of `state`'s pose.
  void update_friction(const Eigen::VectorXd& state) noexcept;
  double gaussian() noexcept;

  SimulatorOptions options_;
  VehicleModel<double> model_;
  DiscreteDynamics<double> dynamics_;
  DiscreteDynamics<double>::Data dynamics_data_;
  int substeps_;
  double time_ = 0.0;
  Eigen::VectorXd state_, next_state_, input_, state_dot_, measurement_;
  std::vector<ModuleDiagnostics<double>> diagnostics_;
  std::vector<double> module_wear_, step_module_wear_, period_module_wear_;
  double frictional_energy_ = 0.0;
  std::vector<PlantModuleSample> samples_;
  ModuleFaults active_faults_;
  std::vector<double> friction_scales_;  // observed by model_ (VehicleModel::observe_friction_scales)
  std::deque<Eigen::VectorXd> delayed_;  // true prefixes awaiting their delay
  std::uint64_t rng_state_ = 0;
};

}  // namespace swerve
