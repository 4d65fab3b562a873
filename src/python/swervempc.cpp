// The Python module `swervempc` (pybind11): load configs, build a controller and step it with numpy
// arrays, close the loop on the simulated plant, run scenarios and sweeps, from a notebook. A thin
// front end over the library, like the CLI: every ConfigError surfaces as a ValueError with the
// library's message, and every array is checked for its shape before it reaches C++.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <variant>
#include <vector>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/run_logs.hpp"
#include "swerve/app/run_report.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/scenario_runner.hpp"
#include "swerve/app/sweep.hpp"
#include "swerve/app/trajectory_file.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/control/reference.hpp"
#include "swerve/kinematics/module_faults.hpp"
#include "swerve/sim/simulator.hpp"
#include "swerve/version.hpp"

namespace py = pybind11;

namespace swerve::python {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A 1-D array of exactly `size` values, as an Eigen vector; ValueError naming `what` otherwise.
Eigen::VectorXd vector_of(const Array& values, py::ssize_t size, const std::string& what) {
  if (values.ndim() != 1 || values.shape(0) != size) {
    std::string shape = "(";
    for (py::ssize_t d = 0; d < values.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(values.shape(d));
    if (values.ndim() == 1) shape += ",";
    throw py::value_error(what + ": expected a 1-D array of " + std::to_string(size) + " values, got shape " +
                          shape + ")");
  }
  Eigen::VectorXd v(size);
  for (py::ssize_t i = 0; i < size; ++i) v(i) = values.at(i);
  return v;
}

Array array_of(const std::vector<double>& values) {
  Array a(static_cast<py::ssize_t>(values.size()));
  std::copy(values.begin(), values.end(), a.mutable_data());
  return a;
}

Array array_of(const Eigen::VectorXd& values) {
  Array a(values.size());
  std::copy(values.data(), values.data() + values.size(), a.mutable_data());
  return a;
}

// The state layout every controller and the plant use, for error messages.
std::string state_layout(int modules) {
  return "state (x, y, psi, vx, vy, r, then " + std::to_string(modules) + " steering angles)";
}

// ---- controller output ----------------------------------------------------------------------------
// One step's answer, copied out of the controller (whose own output is overwritten next step).
struct PyControlOutput {
  Array steering_angle, steering_rate, wheel_speed;  // per module: rad, rad/s, wheel rad/s
  std::string source, reason, solve_status, solve_reason;
  int solve_iterations = -1;
  double cost = -1.0, solve_time = -1.0, step_time = -1.0;
  bool measurement_stale = false;

  explicit PyControlOutput(const ControlOutput& out) {
    const int n = out.modules.size();
    steering_angle = Array(n);
    steering_rate = Array(n);
    wheel_speed = Array(n);
    for (int i = 0; i < n; ++i) {
      steering_angle.mutable_at(i) = out.modules[i].steering_angle;
      steering_rate.mutable_at(i) = out.modules[i].steering_rate;
      wheel_speed.mutable_at(i) = out.modules[i].wheel_speed;
    }
    source = to_string(out.source);
    reason = out.reason;
    solve_status = to_string(out.solve.status);
    solve_reason = out.solve.reason;
    solve_iterations = out.solve.iterations;
    cost = out.solve.status == SolveStatus::kNotRun ? -1.0 : out.solve.cost.total();
    solve_time = out.solve.solve_time_s;
    step_time = out.step_time_s;
    measurement_stale = out.measurement_stale;
  }
};

ModuleArray<ModuleCommand> commands_of(const Array& steering_angle, const Array& steering_rate,
                                       const Array& wheel_speed, int modules) {
  const Eigen::VectorXd angle = vector_of(steering_angle, modules, "steering_angle");
  const Eigen::VectorXd rate = vector_of(steering_rate, modules, "steering_rate");
  const Eigen::VectorXd speed = vector_of(wheel_speed, modules, "wheel_speed");
  ModuleArray<ModuleCommand> commands(modules);
  for (int i = 0; i < modules; ++i) commands[i] = {angle(i), rate(i), speed(i)};
  return commands;
}

std::shared_ptr<const Reference> reference_or_throw(std::shared_ptr<TrajectoryReference> reference) {
  if (!reference) throw py::value_error("reference: must not be None");
  return reference;
}

// ---- controller -----------------------------------------------------------------------------------
// A controller with the reference it tracks kept alive beside it.
class PyController {
 public:
  PyController(std::unique_ptr<TrackingController> controller, std::shared_ptr<const Reference> reference,
               int modules)
      : controller_(std::move(controller)), reference_(std::move(reference)), modules_(modules) {}

  PyControlOutput step(const Array& measured_state, double t, std::optional<double> measured_at) {
    const Eigen::VectorXd state = vector_of(measured_state, 6 + modules_, state_layout(modules_));
    if (!std::isfinite(t)) throw py::value_error("t = " + std::to_string(t) + ": must be finite");
    // A non-finite measurement is the controller's to judge (it stops safely and says why).
    return PyControlOutput(controller_->step(state, t, measured_at.value_or(t)));
  }
  void set_reference(std::shared_ptr<TrajectoryReference> reference) {
    std::shared_ptr<const Reference> tracked = reference_or_throw(std::move(reference));
    controller_->set_reference(tracked);
    reference_ = std::move(tracked);
  }
  bool prepare(double t_next) {
    if (!std::isfinite(t_next)) throw py::value_error("t_next = " + std::to_string(t_next) + ": must be finite");
    return controller_->prepare(t_next);
  }
  void reset() { controller_->reset(); }
  std::string name() const { return controller_->name(); }
  int modules() const { return modules_; }
  // What the vehicle knows besides its measurements (TrackingController): a module's fault, the
  // floor's grip, each tire's wear so far. A bad one raises ValueError naming it.
  void set_module_fault(int module, const std::string& kind) {
    controller_->set_module_fault(module, module_fault_from_string(kind, "set_module_fault.kind"));
  }
  std::vector<std::string> module_faults() const {
    std::vector<std::string> words;
    for (int i = 0; i < modules_; ++i) words.emplace_back(to_string(controller_->module_faults()[i]));
    return words;
  }
  void set_friction_scale(double scale) { controller_->set_friction_scale(scale); }
  void set_module_wear(const Array& wear) {
    controller_->set_module_wear(vector_of(wear, modules_, "set_module_wear.wear"));
  }

 private:
  std::unique_ptr<TrackingController> controller_;
  std::shared_ptr<const Reference> reference_;
  int modules_;
};

// ---- runs -----------------------------------------------------------------------------------------
py::dict metrics_dict(const RunMetrics& m) {
  py::dict d;
  d["steps"] = m.steps;
  d["tracking_rmse_m"] = m.tracking_rmse_m;
  d["tracking_max_m"] = m.tracking_max_m;
  d["heading_rmse_rad"] = m.heading_rmse_rad;
  d["heading_max_rad"] = m.heading_max_rad;
  d["wear_total"] = m.wear_total;
  d["wear_per_module"] = array_of(m.wear_per_module);
  d["wear_imbalance"] = m.wear_imbalance;
  d["lifetime_wear_imbalance"] = m.lifetime_wear_imbalance;
  d["frictional_energy_J"] = m.frictional_energy_J;
  d["steering_effort"] = m.steering_effort;
  d["steering_command_jerk"] = m.steering_command_jerk;
  d["solve_time_mean_ms"] = m.solve_time_mean_ms;
  d["solve_time_p50_ms"] = m.solve_time_p50_ms;
  d["solve_time_p99_ms"] = m.solve_time_p99_ms;
  d["solve_time_max_ms"] = m.solve_time_max_ms;
  d["step_time_p99_ms"] = m.step_time_p99_ms;
  d["step_time_max_ms"] = m.step_time_max_ms;
  d["deadline_misses"] = m.deadline_misses;
  d["late_solves"] = m.late_solves;
  d["work_budget_cuts"] = m.work_budget_cuts;
  d["fallbacks"] = m.fallbacks;
  d["tracking_first_steps"] = m.tracking_first_steps;
  d["solve_iterations_mean"] = m.solve_iterations_mean;
  return d;
}

// The per-step log as columns: 1-D arrays of one value per step, (steps, modules) arrays per module.
py::dict log_dict(const std::vector<StepRecord>& log) {
  const auto steps = static_cast<py::ssize_t>(log.size());
  const py::ssize_t modules = log.empty() ? 0 : static_cast<py::ssize_t>(log.front().commands.size());
  const auto column = [&](auto value_of) {
    Array a(steps);
    for (py::ssize_t k = 0; k < steps; ++k) a.mutable_at(k) = value_of(log[static_cast<std::size_t>(k)]);
    return a;
  };
  const auto per_module = [&](auto value_of) {
    Array a({steps, modules});
    for (py::ssize_t k = 0; k < steps; ++k) {
      const StepRecord& r = log[static_cast<std::size_t>(k)];
      for (py::ssize_t i = 0; i < modules; ++i) a.mutable_at(k, i) = value_of(r, static_cast<std::size_t>(i));
    }
    return a;
  };
  py::dict d;
  d["t"] = column([](const StepRecord& r) { return r.t; });
  d["x"] = column([](const StepRecord& r) { return r.pose_world.x(); });
  d["y"] = column([](const StepRecord& r) { return r.pose_world.y(); });
  d["psi"] = column([](const StepRecord& r) { return r.pose_world.z(); });
  d["vx"] = column([](const StepRecord& r) { return r.twist_body.x(); });
  d["vy"] = column([](const StepRecord& r) { return r.twist_body.y(); });
  d["r"] = column([](const StepRecord& r) { return r.twist_body.z(); });
  d["x_ref"] = column([](const StepRecord& r) { return r.reference_pose_world.x(); });
  d["y_ref"] = column([](const StepRecord& r) { return r.reference_pose_world.y(); });
  d["psi_ref"] = column([](const StepRecord& r) { return r.reference_pose_world.z(); });
  d["position_error"] = column([](const StepRecord& r) { return r.position_error(); });
  d["heading_error"] = column([](const StepRecord& r) { return r.heading_error(); });
  d["solve_time"] = column([](const StepRecord& r) { return r.solve_time_s; });
  d["step_time"] = column([](const StepRecord& r) { return r.step_time_s; });
  d["solve_iterations"] = column([](const StepRecord& r) { return static_cast<double>(r.solve_iterations); });
  // The optimiser's predicted costs (as the CSV's plan_* columns); NaN where no optimiser ran.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  d["plan_tracking_cost"] = column([&](const StepRecord& r) { return r.has_plan_cost() ? r.plan_cost.tracking : nan; });
  d["plan_wear_cost"] = column([&](const StepRecord& r) { return r.has_plan_cost() ? r.plan_cost.wear : nan; });
  d["plan_cost"] = column([&](const StepRecord& r) { return r.has_plan_cost() ? r.plan_cost.total() : nan; });
  d["initial_guess_cost"] = column([&](const StepRecord& r) { return r.has_plan_cost() ? r.initial_guess_cost : nan; });
  py::list source, status;
  for (const StepRecord& r : log) {
    source.append(to_string(r.source));
    status.append(to_string(r.solve_status));
  }
  d["source"] = source;
  d["solve_status"] = status;
  d["steering_angle"] = per_module([](const StepRecord& r, std::size_t i) { return r.modules[i].steering_angle; });
  d["wheel_speed"] = per_module([](const StepRecord& r, std::size_t i) { return r.modules[i].wheel_speed; });
  d["slip_angle"] = per_module([](const StepRecord& r, std::size_t i) { return r.modules[i].slip_angle; });
  d["slip_ratio"] = per_module([](const StepRecord& r, std::size_t i) { return r.modules[i].slip_ratio; });
  d["wear"] = per_module([](const StepRecord& r, std::size_t i) { return r.modules[i].wear; });
  d["command_steering_rate"] =
      per_module([](const StepRecord& r, std::size_t i) { return r.commands[i].steering_rate; });
  d["command_wheel_speed"] = per_module([](const StepRecord& r, std::size_t i) { return r.commands[i].wheel_speed; });
  return d;
}

py::dict run_dict(const ControllerRun& run, bool with_log) {
  py::dict d;
  d["name"] = run.name;
  d["type"] = to_string(run.kind);
  d["backend"] = run.backend.empty() ? py::object(py::none()) : py::object(py::str(run.backend));
  d["wear_weight"] = run.wear_weight;
  d["effective_wear_weight"] = run.effective_wear_weight;
  d["solve_budget"] = run.solve_budget;
  d["completed"] = run.completed;
  d["failure"] = run.failure.empty() ? py::object(py::none()) : py::object(py::str(run.failure));
  d["metrics"] = metrics_dict(run.metrics);
  if (with_log) d["log"] = log_dict(run.log);
  return d;
}

RunOverrides overrides_of(std::optional<std::vector<std::string>> controllers, std::optional<std::uint64_t> seed,
                          std::optional<std::string> backend) {
  RunOverrides o;
  if (controllers) o.controllers = *controllers;
  o.seed = seed;
  o.backend = std::move(backend);
  return o;
}

py::dict run_scenario_file(const std::string& path, std::optional<std::vector<std::string>> controllers,
                           std::optional<std::uint64_t> seed, std::optional<std::string> backend,
                           std::optional<double> wear_weight, std::optional<std::string> out_dir,
                           const std::string& log) {
  RunOverrides o = overrides_of(std::move(controllers), seed, std::move(backend));
  o.wear_weight = wear_weight;
  const LogFormats formats = parse_log_formats(log);  // checked before the runs
  std::vector<ControllerRun> runs;
  {
    py::gil_scoped_release release;  // minutes of simulation: let other Python threads run
    const ScenarioConfig scenario = apply_overrides(load_scenario_config_file(path), o);
    runs = run_scenario(scenario);
    // What `swerve-mpc run --out DIR --log ...` writes.
    if (out_dir) write_run_outputs(scenario, runs, *out_dir, formats);
  }
  py::dict result;
  for (const ControllerRun& run : runs) result[py::str(run.name)] = run_dict(run, true);
  return result;
}

py::dict sweep_file(const std::string& path, std::optional<std::vector<double>> wear_weights,
                    std::optional<std::vector<double>> tolerances, double heading_tolerance,
                    std::optional<std::uint64_t> seed, std::optional<std::string> backend, bool logs) {
  if (wear_weights.has_value() == tolerances.has_value()) {
    throw py::value_error("sweep: give exactly one of wear_weights and tolerances");
  }
  std::vector<SweepPoint> points;
  if (wear_weights) {
    for (const double w : *wear_weights) points.push_back({w, std::nullopt});
  } else {
    for (const double position : *tolerances) {
      TrackingTolerance t;
      t.position = position;
      t.heading = heading_tolerance;
      points.push_back({std::nullopt, t});
    }
  }
  std::optional<SweepResult> result;
  {
    py::gil_scoped_release release;
    const ScenarioConfig scenario = load_scenario_config_file(path);
    result.emplace(run_sweep(scenario, overrides_of(std::nullopt, seed, std::move(backend)), points));
  }
  py::list point_list;
  for (const SweepRun& p : result->points) {
    py::dict d = run_dict(p.run, logs);
    if (p.point.tolerance) {
      d["tolerance_position_m"] = p.point.tolerance->position;
      d["tolerance_heading_rad"] = p.point.tolerance->heading;
    }
    point_list.append(d);
  }
  py::dict out;
  out["scenario"] = result->baseline_scenario.name;
  out["swept"] = wear_weights ? "wear_weight" : "tracking_tolerance";
  out["baseline"] = run_dict(result->baseline, logs);
  if (result->practical) out["practical_baseline"] = run_dict(*result->practical, logs);
  out["points"] = point_list;
  return out;
}


void bind_vehicle(py::module_& m) {
  py::class_<VehicleParams>(m, "Vehicle", "A vehicle: mass, inertia and the module layout (load_vehicle)")
      .def_readonly("name", &VehicleParams::name)
      .def_readonly("mass", &VehicleParams::mass, "kg")
      .def_readonly("yaw_inertia", &VehicleParams::yaw_inertia, "kg m^2")
      .def_property_readonly("module_count", [](const VehicleParams& v) { return v.layout.size(); })
      .def_property_readonly("module_positions",
                             [](const VehicleParams& v) {
                               const auto n = static_cast<py::ssize_t>(v.layout.size());
                               Array a({n, py::ssize_t{2}});
                               for (py::ssize_t i = 0; i < n; ++i) {
                                 a.mutable_at(i, 0) = v.layout.position_body(static_cast<int>(i)).x();
                                 a.mutable_at(i, 1) = v.layout.position_body(static_cast<int>(i)).y();
                               }
                               return a;
                             },
                             "(modules, 2) body-frame positions, m")
      .def_property_readonly("wheel_radius", [](const VehicleParams& v) { return v.layout.wheel_radius(); })
      .def_property_readonly("max_drive_speed",
                             [](const VehicleParams& v) { return v.layout.limits().max_drive_speed; });
  m.def("load_vehicle", &load_vehicle_config_file, py::arg("path"), "Loads a vehicle file (its `vehicle:` section)");
}

// ---- kinematics -----------------------------------------------------------------------------------
// A vehicle's kinematics with the heading memory its command chain keeps (flip decisions, held
// headings), so successive command() calls behave as on the vehicle.
class PyKinematics {
 public:
  PyKinematics(const VehicleParams& vehicle, const KinematicsOptions& options)
      : kinematics_(vehicle.layout, options), memory_(vehicle.layout.size()), modules_(vehicle.layout.size()) {}

  py::tuple inverse(const Array& twist_body, const py::object& center_of_rotation) const {
    ModuleStates states(modules_);
    check("inverse",
          kinematics_.inverse(vector_of(twist_body, 3, "twist_body"), &states, center_of(center_of_rotation)));
    return speeds_and_angles(states);
  }
  Array forward(const Array& speeds, const Array& angles) const {
    Eigen::Vector3d twist;
    check("forward", kinematics_.forward(states_of(speeds, angles), &twist));
    return array_of(Eigen::VectorXd(twist));
  }
  py::tuple command(const Array& twist_body, const py::object& center_of_rotation, const py::object& measured_angles) {
    ModuleStates states(modules_);
    ModuleStates measured(modules_);
    const bool has_measured = !measured_angles.is_none();
    if (has_measured) {
      const Eigen::VectorXd angles = vector_of(measured_angles.cast<Array>(), modules_, "measured_angles");
      for (int i = 0; i < modules_; ++i) measured[i].angle = angles[i];
    }
    check("command", kinematics_.command(vector_of(twist_body, 3, "twist_body"), &memory_, &states,
                                         center_of(center_of_rotation), has_measured ? &measured : nullptr));
    return speeds_and_angles(states);
  }
  // WPILib's optimize per module: (angle + pi, -speed) when that steers less from current_angles.
  py::tuple flip(const Array& speeds, const Array& angles, const Array& current_angles) const {
    ModuleStates states = states_of(speeds, angles);
    const Eigen::VectorXd current = vector_of(current_angles, modules_, "current_angles");
    if (!current.allFinite()) throw py::value_error("current_angles: must be finite");
    for (int i = 0; i < modules_; ++i) states[i] = optimize_module(states[i], current[i]);
    return speeds_and_angles(states);
  }
  Array desaturate(const Array& speeds, double max_speed) const {
    const Eigen::VectorXd v = vector_of(speeds, modules_, "speeds");
    ModuleStates states(modules_);
    for (int i = 0; i < modules_; ++i) states[i].speed = v[i];
    check("desaturate", Kinematics::desaturate(max_speed, &states));
    Eigen::VectorXd out(modules_);
    for (int i = 0; i < modules_; ++i) out[i] = states[i].speed;
    return array_of(out);
  }
  Array desaturate_twist(const Array& twist_body, double max_module_speed, const std::string& priority) const {
    DesaturationPriority chosen = DesaturationPriority::kProportional;
    if (priority == "keep_rotation") {
      chosen = DesaturationPriority::kKeepRotation;
    } else if (priority == "keep_translation") {
      chosen = DesaturationPriority::kKeepTranslation;
    } else if (priority != "proportional") {
      throw py::value_error("priority = '" + priority + "': expected proportional, keep_rotation or keep_translation");
    }
    Eigen::Vector3d out;
    check("desaturate_twist",
          kinematics_.desaturate_twist(vector_of(twist_body, 3, "twist_body"), max_module_speed, chosen, &out));
    return array_of(Eigen::VectorXd(out));
  }
  void reset() noexcept { memory_.reset(); }
  int modules() const noexcept { return modules_; }

 private:
  static void check(const char* what, KinematicsStatus status) {
    if (status != KinematicsStatus::kOk) throw py::value_error(std::string(what) + ": " + to_string(status));
  }
  ModuleStates states_of(const Array& speeds, const Array& angles) const {
    const Eigen::VectorXd v = vector_of(speeds, modules_, "speeds");
    const Eigen::VectorXd a = vector_of(angles, modules_, "angles");
    ModuleStates states(modules_);
    for (int i = 0; i < modules_; ++i) states[i] = {v[i], a[i]};
    return states;
  }
  static Eigen::Vector2d center_of(const py::object& center_of_rotation) {
    if (center_of_rotation.is_none()) return Eigen::Vector2d::Zero();
    return vector_of(center_of_rotation.cast<Array>(), 2, "center_of_rotation");
  }
  py::tuple speeds_and_angles(const ModuleStates& states) const {
    Eigen::VectorXd speeds(modules_), angles(modules_);
    for (int i = 0; i < modules_; ++i) speeds[i] = states[i].speed, angles[i] = states[i].angle;
    return py::make_tuple(array_of(speeds), array_of(angles));
  }

  Kinematics kinematics_;
  ModuleHeadingMemory memory_;
  int modules_;
};

void bind_kinematics(py::module_& m) {
  py::class_<PyKinematics>(m, "Kinematics",
                           "Inverse/forward kinematics of a vehicle's layout and the module command chain "
                           "(desaturate, singularity hold, flip with memory, cosine scaling)")
      .def(py::init([](const VehicleParams& vehicle, double flip_hysteresis, bool whole_robot_flip,
                       bool cosine_scaling) {
             KinematicsOptions options;
             options.flip_hysteresis = flip_hysteresis;
             options.whole_robot_flip = whole_robot_flip;
             options.cosine_scaling = cosine_scaling;
             return PyKinematics(vehicle, options);  // ConfigError (ValueError) names a bad option
           }),
           py::arg("vehicle"), py::arg("flip_hysteresis") = KinematicsOptions{}.flip_hysteresis,
           py::arg("whole_robot_flip") = false, py::arg("cosine_scaling") = true)
      .def_property_readonly("module_count", &PyKinematics::modules)
      .def("inverse", &PyKinematics::inverse, py::arg("twist_body"), py::arg("center_of_rotation") = py::none(),
           "(speeds m/s, angles rad) per module for the body twist (vx, vy, r) about the centre of rotation")
      .def("forward", &PyKinematics::forward, py::arg("speeds"), py::arg("angles"),
           "The least-squares body twist (vx, vy, r) of the module velocities")
      .def("command", &PyKinematics::command, py::arg("twist_body"),
           py::arg("center_of_rotation") = py::none(), py::arg("measured_angles") = py::none(),
           "The command chain for hardware (inverse, desaturate to the layout's drive speed, singularity hold, "
           "flip with hysteresis, cosine scaling against measured_angles); remembers headings between calls")
      .def("flip", &PyKinematics::flip, py::arg("speeds"), py::arg("angles"), py::arg("current_angles"),
           "Per module, (angle + pi, -speed) when that steers less from current_angles (no memory)")
      .def("desaturate", &PyKinematics::desaturate, py::arg("speeds"), py::arg("max_speed"),
           "Every speed scaled by one factor so none exceeds max_speed (signs kept)")
      .def("desaturate_twist", &PyKinematics::desaturate_twist, py::arg("twist_body"), py::arg("max_module_speed"),
           py::arg("priority") = "proportional",
           "The largest twist within the module speed limit: proportional, keep_rotation or keep_translation")
      .def("reset", &PyKinematics::reset, "Forgets the remembered headings and flip decisions");
}

void bind_controller_config(py::module_& m) {
  py::class_<ControllerConfig>(m, "ControllerConfig",
                               "A controller file's settings; change them, then make_controller validates them")
      .def_readonly("name", &ControllerConfig::name)
      .def_property_readonly("type", [](const ControllerConfig& c) { return std::string(to_string(c.kind)); })
      .def_property(
          "horizon", [](const ControllerConfig& c) { return c.mpc.horizon; },
          [](ControllerConfig& c, int n) { c.set_sampling(n, c.mpc.dt); })
      .def_property(
          "dt", [](const ControllerConfig& c) { return c.mpc.dt; },
          [](ControllerConfig& c, double dt) { c.set_sampling(c.mpc.horizon, dt); },
          "s, the prediction's step; the control period too unless control_period is set")
      .def_property(
          "control_period", [](const ControllerConfig& c) { return c.period(); },
          [](ControllerConfig& c, double period) { c.mpc.control_period = period; },
          "s between steps (wear_mpc: at most dt; setting it to dt or 0 steps every dt)")
      .def_property(
          "solve_budget", [](const ControllerConfig& c) { return c.mpc.solve_budget; },
          [](ControllerConfig& c, double s) { c.mpc.solve_budget = s; })
      .def_property(
          "wear_weight", [](const ControllerConfig& c) { return c.mpc.wear_weight; },
          [](ControllerConfig& c, double w) { c.mpc.wear_weight = w; })
      .def_property(
          "backend", [](const ControllerConfig& c) { return c.solver.backend; },
          [](ControllerConfig& c, const std::string& b) { c.solver.backend = b; })
      .def_property(
          "tracking_tolerance",
          [](const ControllerConfig& c) -> std::optional<std::pair<double, double>> {
            if (!c.mpc.tracking_tolerance.enabled()) return std::nullopt;
            return std::make_pair(c.mpc.tracking_tolerance.position, c.mpc.tracking_tolerance.heading);
          },
          [](ControllerConfig& c, std::optional<std::pair<double, double>> tube) {
            c.mpc.tracking_tolerance.position = tube ? tube->first : 0.0;
            c.mpc.tracking_tolerance.heading = tube ? tube->second : 0.0;
          },
          "(position m, heading rad), or None for the wear-weight mode")
      .def_property(
          "stale_measurement",
          [](const ControllerConfig& c) {
            const StalenessOptions& o = c.mpc.stale_measurement;
            return py::make_tuple(o.max_age, o.frozen_cycles, o.moving_speed);
          },
          [](ControllerConfig& c, const std::tuple<double, int, double>& limits) {
            StalenessOptions& o = c.mpc.stale_measurement;
            std::tie(o.max_age, o.frozen_cycles, o.moving_speed) = limits;
          },
          "(max_age s (0: what the latency compensation covers), frozen_cycles, moving_speed m/s): when a "
          "measurement is too old or frozen to act on")
      .def_property(
          "polish_share", [](const ControllerConfig& c) { return c.solver.sa.polish_share; },
          [](ControllerConfig& c, double share) { c.solver.sa.polish_share = share; },
          "SA: the share of the budget for the gradient polish from SA's best (0: none)")
      .def("validate", &ControllerConfig::validate, "Raises ValueError naming the field and value");
  m.def("load_controller_config", &load_controller_config_file, py::arg("path"),
        "Loads a controller file (its `controller:` section)");
}

void bind_reference(py::module_& m) {
  py::class_<TrajectoryReference, std::shared_ptr<TrajectoryReference>>(
      m, "TrajectoryReference", "A planner-fed reference: publish time-stamped samples, the controller tracks the newest")
      .def(py::init<int, double>(), py::arg("capacity"), py::arg("max_age") = std::numeric_limits<double>::infinity())
      .def(
          "publish",
          [](TrajectoryReference& reference, const Array& samples) {
            if (samples.ndim() != 2) {
              throw py::value_error("samples: expected a 2-D array (rows t, x, y, psi[, vx, vy, r]), got " +
                                    std::to_string(samples.ndim()) + " dimensions");
            }
            Eigen::MatrixXd rows(samples.shape(0), samples.shape(1));
            for (py::ssize_t i = 0; i < samples.shape(0); ++i) {
              for (py::ssize_t j = 0; j < samples.shape(1); ++j) rows(i, j) = samples.at(i, j);
            }
            const TrajectoryCheck check = reference.publish(rows);
            if (!check.accepted()) throw py::value_error("samples: " + check.describe());
          },
          py::arg("samples"),
          "Rows (t, x, y, psi[, vx, vy, r]) on the controller's clock; ValueError naming the sample if refused "
          "(the previous trajectory stays active)")
      .def(
          "sample",
          [](const TrajectoryReference& reference, double t) {
            if (!std::isfinite(t)) throw py::value_error("t: must be finite, got " + std::to_string(t));
            // As a controller cycle begins: the newest published trajectory is taken up first.
            reference.begin_cycle();
            if (reference.version() == 0) throw py::value_error("sample: no trajectory has been published yet");
            const ReferenceSample sample = reference.sample(t);
            return py::make_tuple(array_of(sample.pose_world), array_of(sample.twist_body));
          },
          py::arg("t"),
          "(pose_world (x, y, psi), twist_body (vx, vy, r)) at t on the controller's clock, from the newest "
          "published trajectory (taken up as a controller cycle would); ValueError before any trajectory or for a "
          "non-finite t")
      .def_property_readonly("version", &TrajectoryReference::version,
                             "Trajectories taken up so far (by a controller cycle or sample()); 0 before any")
      .def_property_readonly("duration", &TrajectoryReference::duration);
  const auto rows_array = [](const Eigen::MatrixXd& rows) {
    Array a({static_cast<py::ssize_t>(rows.rows()), static_cast<py::ssize_t>(rows.cols())});
    for (Eigen::Index i = 0; i < rows.rows(); ++i) {
      for (Eigen::Index j = 0; j < rows.cols(); ++j) a.mutable_at(i, j) = rows(i, j);
    }
    return a;
  };
  m.def(
      "load_choreo_trajectory",
      [rows_array](const std::string& path, const std::string& trajectory, int split, int modules, double max_speed) {
        ChoreoOptions options;
        options.trajectory = trajectory;
        options.split = split;
        options.modules = modules;
        options.max_speed = max_speed;
        return rows_array(load_choreo_trajectory(path, options));
      },
      py::arg("path"), py::arg("trajectory") = "", py::arg("split") = -1, py::arg("modules") = 0,
      py::arg("max_speed") = std::numeric_limits<double>::infinity(),
      "Rows (t, x, y, psi[, vx, vy, r], body-frame twist) of a Choreo .traj file, or of <path>/<trajectory>.traj "
      "when path is a folder; split k: its k-th segment; modules > 0: the module forces' count to check. "
      "ValueError naming the file, sample and field");
  m.def(
      "load_pose_list", [rows_array](const std::string& path, double max_speed) {
        return rows_array(load_pose_list(path, max_speed));
      },
      py::arg("path"), py::arg("max_speed") = std::numeric_limits<double>::infinity(),
      "Rows (t, x, y, psi) of a JSON pose list (flat t/x/y/psi objects or nav_msgs/Path-like stamped poses)");
}

void bind_controller(py::module_& m) {
  py::class_<PyControlOutput>(m, "ControlOutput", "One controller step's module commands and status")
      .def_readonly("steering_angle", &PyControlOutput::steering_angle, "rad, per module")
      .def_readonly("steering_rate", &PyControlOutput::steering_rate, "rad/s, per module")
      .def_readonly("wheel_speed", &PyControlOutput::wheel_speed, "wheel rad/s, per module")
      .def_readonly("source", &PyControlOutput::source, "optimizer, tracking_first, previous_plan, baseline, safe_stop")
      .def_readonly("reason", &PyControlOutput::reason)
      .def_readonly("solve_status", &PyControlOutput::solve_status)
      .def_readonly("solve_reason", &PyControlOutput::solve_reason)
      .def_readonly("solve_iterations", &PyControlOutput::solve_iterations)
      .def_readonly("cost", &PyControlOutput::cost, "of the returned plan; -1 when no solve ran")
      .def_readonly("solve_time", &PyControlOutput::solve_time, "s")
      .def_readonly("step_time", &PyControlOutput::step_time, "s")
      .def_readonly("measurement_stale", &PyControlOutput::measurement_stale);

  py::class_<PyController>(m, "Controller", "A tracking controller (make_controller)")
      .def("step", &PyController::step, py::arg("measured_state"), py::arg("t"), py::arg("measured_at") = py::none(),
           "One control period: the measured state (x, y, psi, vx, vy, r, steering angles) at time t")
      .def("prepare", &PyController::prepare, py::arg("t_next"),
           "After sending step's commands: the next step's work that needs no measurement (rti's "
           "preparation), so the step at t_next only runs the feedback. True when something was prepared")
      .def("set_reference", &PyController::set_reference, py::arg("reference"))
      .def("reset", &PyController::reset)
      .def("set_module_fault", &PyController::set_module_fault, py::arg("module"), py::arg("kind"),
           "A known fault from the next step on: none, stuck_steering, dead_drive or steering_sensor_lost")
      .def_property_readonly("module_faults", &PyController::module_faults,
                             "Each module's fault: those set and those the controller's detector found")
      .def("set_friction_scale", &PyController::set_friction_scale, py::arg("scale"),
           "The floor's grip as a multiple of the tire's mu, in (0, 10]")
      .def("set_module_wear", &PyController::set_module_wear, py::arg("wear"),
           "Each tire's wear so far (one entry >= 0 per module); weighs each module's wear with wear_balancing")
      .def_property_readonly("name", &PyController::name)
      .def_property_readonly("module_count", &PyController::modules);
  m.def(
      "make_controller",
      [](const std::string& vehicle_yaml, const std::string& controller_yaml,
         std::shared_ptr<TrajectoryReference> reference) {
        const std::shared_ptr<const Reference> tracked = reference_or_throw(std::move(reference));
        const int modules = load_vehicle_config_file(vehicle_yaml).layout.size();
        return PyController(make_controller(vehicle_yaml, controller_yaml, tracked), tracked, modules);
      },
      py::arg("vehicle_yaml"), py::arg("controller_yaml"), py::arg("reference"),
      "A controller from a vehicle file and a controller file, tracking `reference`");
  m.def(
      "make_controller",
      [](const ControllerConfig& config, const VehicleParams& vehicle, std::shared_ptr<TrajectoryReference> reference) {
        config.validate();
        const std::shared_ptr<const Reference> tracked = reference_or_throw(std::move(reference));
        return PyController(make_controller(config, vehicle, tracked), tracked, vehicle.layout.size());
      },
      py::arg("config"), py::arg("vehicle"), py::arg("reference"),
      "A controller from loaded (and possibly changed) settings");
}

void bind_simulator(py::module_& m) {
  py::class_<Simulator>(m, "Simulator", "The plant: rigid body, Magic Formula tires, wear, actuator lags")
      .def(py::init([](const VehicleParams& vehicle, double control_period, std::uint64_t seed,
                       int measurement_delay_steps, const std::optional<py::dict>& noise) {
             SimulatorOptions options;
             options.control_period = control_period;
             options.seed = seed;
             options.measurement_delay_steps = measurement_delay_steps;
             if (noise) {
               // The keys and rules of a scenario's `simulator: noise:` block (MeasurementNoise::fields()).
               const OptionFields<MeasurementNoise>& fields = MeasurementNoise::fields();
               for (const auto& [key, value] : *noise) {
                 const std::string name = py::str(key);
                 double MeasurementNoise::* member = nullptr;
                 std::string known;
                 for (const OptionField<MeasurementNoise>& field : fields) {
                   known += (known.empty() ? "" : ", ") + std::string(field.yaml_key());
                   if (name == field.yaml_key()) member = std::get<double MeasurementNoise::*>(field.member);
                 }
                 if (member == nullptr) throw py::value_error("noise." + name + ": unknown (" + known + ")");
                 options.noise.*member = value.cast<double>();
               }
             }
             return std::make_unique<Simulator>(vehicle, options);  // validates, naming the field and value
           }),
           py::arg("vehicle"), py::arg("control_period") = 0.05, py::arg("seed") = 1,
           py::arg("measurement_delay_steps") = 0, py::arg("noise") = py::none(),
           "noise: standard deviations {position (m), heading (rad), velocity (m/s), yaw_rate (rad/s), "
           "steering_angle (rad)} on the measurement; measurement_delay_steps: the measurement is that many periods "
           "old")
      .def(
          "reset",
          [](Simulator& plant, const Array& initial_state) {
            plant.reset(vector_of(initial_state, 6 + plant.modules(), "initial " + state_layout(plant.modules())));
          },
          py::arg("initial_state"))
      .def(
          "advance",
          [](Simulator& plant, const PyControlOutput& out) {
            return plant.advance(commands_of(out.steering_angle, out.steering_rate, out.wheel_speed, plant.modules()));
          },
          py::arg("output"), "One control period under a controller's commands; False when the plant diverged")
      .def(
          "advance",
          [](Simulator& plant, const Array& steering_angle, const Array& steering_rate, const Array& wheel_speed) {
            return plant.advance(commands_of(steering_angle, steering_rate, wheel_speed, plant.modules()));
          },
          py::arg("steering_angle"), py::arg("steering_rate"), py::arg("wheel_speed"))
      .def_property_readonly("measurement", [](const Simulator& plant) { return array_of(plant.measurement()); },
                             "What a controller is given: delayed and noisy as configured")
      .def_property_readonly("state", [](const Simulator& plant) { return array_of(plant.state()); },
                             "The plant's true full state now (pose, twist, then per module steering and the rest)")
      .def_property_readonly("measurement_age", &Simulator::measurement_age, "s: how old the measurement is")
      .def_property_readonly("frictional_energy", &Simulator::frictional_energy,
                             "J dissipated by sliding at all contacts (wheels and casters) so far")
      .def_property_readonly("time", &Simulator::time)
      .def_property_readonly("module_wear", [](const Simulator& plant) { return array_of(plant.module_wear()); })
      .def_property_readonly("module_count", &Simulator::modules);
}

void bind_runs(py::module_& m) {
  m.def("run_scenario", &run_scenario_file, py::arg("path"), py::arg("controllers") = py::none(),
        py::arg("seed") = py::none(), py::arg("backend") = py::none(), py::arg("wear_weight") = py::none(),
        py::arg("out_dir") = py::none(), py::arg("log") = "csv",
        "Runs a scenario file's controllers on the plant: {name: {metrics, log, ...}} (swerve-mpc run); with "
        "out_dir, also writes summary.json and the logs `log` names there (csv, wpilog, mcap)");
  m.def("sweep", &sweep_file, py::arg("path"), py::arg("wear_weights") = py::none(),
        py::arg("tolerances") = py::none(), py::arg("heading_tolerance") = 0.5 * kPi / 180.0,
        py::arg("seed") = py::none(), py::arg("backend") = py::none(), py::arg("logs") = false,
        "The baseline once, then the wear-aware controller at each wear weight or tolerance (swerve-mpc sweep)");
}

}  // namespace
}  // namespace swerve::python

PYBIND11_MODULE(swervempc, m) {
  using namespace swerve;
  using namespace swerve::python;
  m.doc() = "SwerveMPC: tire-wear-aware model-predictive trajectory tracking for swerve-drive vehicles";
  m.attr("__version__") = kVersion;
  // The library's own message, unchanged: "file.yaml: controller.horizon = 0: must be in [1, 1000]".
  py::register_exception_translator([](std::exception_ptr error) {
    try {
      if (error) std::rethrow_exception(error);
    } catch (const ConfigError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  bind_vehicle(m);
  bind_kinematics(m);
  bind_controller_config(m);
  bind_reference(m);
  bind_controller(m);
  bind_simulator(m);
  bind_runs(m);
}
