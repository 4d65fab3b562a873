#include "swerve/app/scenario_config.hpp"

#include <cmath>
#include <sstream>

#include "swerve/app/option_reader.hpp"
#include "swerve/app/trajectory_file.hpp"
#include "swerve/app/vehicle_config.hpp"

namespace swerve {
namespace {

// simulator.faults: [{module, at, kind, announced}], each module of the vehicle once (whether a
// period starts at or after `at` is checked once the period is known).
std::vector<PlantFault> load_plant_faults(const config::ConfigNode& node, int modules) {
  if (!node.is_sequence()) node.fail("expected a list of faults, e.g. [{module: 2, at: 5.0, kind: stuck_steering}]");
  std::vector<PlantFault> faults;
  for (std::size_t f = 0; f < node.size(); ++f) {
    const config::ConfigNode entry = node.at(f);
    PlantFault fault;
    fault.module = entry.get_int("module", 0, modules - 1);
    fault.at = entry.get_double("at", Bound::non_negative());
    fault.kind = module_fault_from_string(entry.get_choice("kind", {"stuck_steering", "dead_drive", "steering_sensor_lost"}), entry.path() + ".kind");
    fault.announced = entry.get_bool_or("announced", false);
    for (const PlantFault& other : faults) {
      if (other.module == fault.module) {
        entry.fail_at("module", "= " + std::to_string(fault.module) + ": module already has a fault in this list");
      }
    }
    faults.push_back(fault);
  }
  return faults;
}

// simulator.friction_patches: [{min: [x, y], max: [x, y], mu}], rectangles in the world
// frame that may touch but not overlap.
std::vector<FrictionPatch> load_friction_patches(const config::ConfigNode& node) {
  if (!node.is_sequence()) node.fail("expected a list of patches, e.g. [{min: [10, -5], max: [20, 5], mu: 0.4}]");
  std::vector<FrictionPatch> patches;
  for (std::size_t p = 0; p < node.size(); ++p) {
    const config::ConfigNode entry = node.at(p);
    FrictionPatch patch;
    const std::vector<double> lower = entry.get_doubles("min", 2, Bound::any());
    const std::vector<double> upper = entry.get_doubles("max", 2, Bound::any());
    patch.min_world = Eigen::Vector2d(lower[0], lower[1]);
    patch.max_world = Eigen::Vector2d(upper[0], upper[1]);
    if (!patch.corners_in_order()) {
      entry.fail_at("max", "= " + entry.child("max").to_yaml() + ": must be greater than min = " +
                                entry.child("min").to_yaml() + " in both x and y (m)");
    }
    patch.mu = entry.get_double("mu", Bound::positive());
    for (std::size_t q = 0; q < patches.size(); ++q) {
      if (patch.overlaps(patches[q])) {
        entry.fail("overlaps friction_patches[" + std::to_string(q) + "] (patches may touch, not overlap)");
      }
    }
    patches.push_back(patch);
  }
  return patches;
}

using config::Bound;
using config::ConfigNode;

// A path named inside a config file is relative to that file's folder (absolute paths stay).
std::string resolve_beside(const std::string& config_file, const std::string& path) {
  if (path.empty() || path.front() == '/') return path;
  const auto slash = config_file.find_last_of('/');
  return slash == std::string::npos ? path : config_file.substr(0, slash + 1) + path;
}

std::string format(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

Eigen::Vector2d get_point_or(const ConfigNode& node, const std::string& key, const Eigen::Vector2d& fallback) {
  if (!node.has(key)) return fallback;
  const std::vector<double> xy = node.get_doubles(key, 2);
  return {xy[0], xy[1]};
}

// A reference read from a file: `type` csv, choreo or pose_list.
std::shared_ptr<const Reference> load_reference_file(const ConfigNode& node, const std::string& type,
                                                     const std::string& scenario_file, double max_speed, int modules,
                                                     std::string* description) {
  const std::string file = resolve_beside(scenario_file, node.get_string("file"));
  ChoreoOptions choreo;
  if (type == "choreo") {
    choreo.trajectory = node.get_string_or("trajectory", "");
    choreo.split = node.get_int_or("split", -1, -1, 1 << 20);
    choreo.modules = modules;
    choreo.max_speed = max_speed;
  }
  const int laps = type == "csv" ? node.get_int_or("laps", 1, 1, 1000) : 1;
  *description = type + " " + file + (choreo.trajectory.empty() ? "" : " trajectory " + choreo.trajectory) +
                 (choreo.split >= 0 ? " split " + std::to_string(choreo.split) : "") +
                 (laps > 1 ? ", " + std::to_string(laps) + " laps" : "");
  try {
    if (type == "csv") return load_reference_csv(file, max_speed, laps);
    const Eigen::MatrixXd rows = type == "choreo" ? load_choreo_trajectory(file, choreo) : load_pose_list(file, max_speed);
    std::vector<std::vector<double>> samples(static_cast<std::size_t>(rows.rows()));
    for (Eigen::Index k = 0; k < rows.rows(); ++k) {
      for (Eigen::Index c = 0; c < rows.cols(); ++c) samples[static_cast<std::size_t>(k)].push_back(rows(k, c));
    }
    return std::make_shared<SampledReference>(samples);
  } catch (const ConfigError& error) {
    node.fail_at("file", std::string("cannot load: ") + error.what());
  }
}

// `max_speed` (m/s): the vehicle's drive speed, which a recorded reference's steps may not exceed;
// `modules`: the vehicle's module count, which a Choreo file's module forces must match.
std::shared_ptr<const Reference> load_reference(const ConfigNode& node, const std::string& scenario_file,
                                                double max_speed, int modules, std::string* description) {
  const std::string type =
      node.get_choice("type", {"line", "arc", "sine", "figure_eight", "csv", "choreo", "pose_list"});
  if (type == "csv" || type == "choreo" || type == "pose_list") {
    return load_reference_file(node, type, scenario_file, max_speed, modules, description);
  }
  SpeedProfile profile;
  profile.speed = node.get_double_or("speed", profile.speed, Bound::positive());
  profile.acceleration = node.get_double_or("acceleration", profile.acceleration, Bound::non_negative());
  profile.stop_at_end = node.get_bool_or("stop_at_end", profile.stop_at_end);
  const double offset = node.get_double_or("heading_offset", 0.0, Bound::closed(-kPi, kPi));
  std::shared_ptr<const PlanarCurve> curve;
  std::string shape;
  try {
    if (type == "line") {
      const double length = node.get_double("length", Bound::positive());
      curve = make_line_curve(get_point_or(node, "start", Eigen::Vector2d::Zero()),
                              node.get_double_or("direction", 0.0), length);
      shape = "line " + format(length) + " m";
    } else if (type == "arc") {
      const double radius = node.get_double("radius", Bound::positive());
      const double sweep = node.get_double("sweep");
      curve = make_arc_curve(get_point_or(node, "start", Eigen::Vector2d::Zero()), node.get_double_or("direction", 0.0),
                             radius, sweep);
      shape = "arc R=" + format(radius) + " m, sweep " + format(sweep * 180.0 / kPi) + " deg";
    } else if (type == "sine") {
      const double amplitude = node.get_double("amplitude", Bound::positive());
      const double wavelength = node.get_double("wavelength", Bound::positive());
      const double length = node.get_double("length", Bound::positive());
      curve = make_sine_curve(amplitude, wavelength, length);
      shape = "sine A=" + format(amplitude) + " m, wavelength " + format(wavelength) + " m, " + format(length) + " m";
    } else {
      const double size = node.get_double("size", Bound::positive());
      const int loops = node.get_int_or("loops", 1, 1, 100);
      curve = make_figure_eight_curve(size, loops);
      shape = "figure-eight " + format(size) + " m x " + std::to_string(loops);
    }
    *description = shape + " at " + format(profile.speed) + " m/s, heading offset " +
                   format(std::round(offset * 180.0 / kPi * 100.0) / 100.0) + " deg";
    return std::make_shared<PathReference>(curve, profile, offset);
  } catch (const ConfigError& error) {
    node.fail(error.what());
  }
}

// The step count of a run, or -1 when it is not a finite number within [1, kMaxScenarioSteps].
int step_count(double duration, double control_period) {
  const double steps = std::ceil(duration / control_period - 1e-9);
  if (!std::isfinite(steps) || steps < 1.0 || steps > kMaxScenarioSteps) return -1;
  return static_cast<int>(steps);
}

std::string step_limit_rule(double control_period) {
  return "must give at most " + std::to_string(kMaxScenarioSteps) + " control periods (" +
         format(kMaxScenarioSteps * control_period) + " s at " + format(control_period) + " s)";
}

// The `initial_state:` block over the state `initial` (6 + n: pose, twist, steering angles), whose
// pose is the reference's start: each of pose, twist and steering (one angle for all, or n) given
// replaces its part.
void read_initial_state(const ConfigNode& initial, int n, Eigen::VectorXd* state) {
  if (initial.has("pose")) {
    const std::vector<double> p = initial.get_doubles("pose", 3);
    state->head<3>() << p[0], p[1], p[2];
  }
  if (initial.has("twist")) {
    const std::vector<double> v = initial.get_doubles("twist", 3);
    state->segment<3>(3) << v[0], v[1], v[2];
  }
  if (initial.has("steering")) {
    const ConfigNode steering = initial.child("steering");
    if (steering.is_scalar()) {
      state->tail(n).setConstant(steering.as_double(Bound::closed(-kPi, kPi)));
    } else {
      const std::vector<double> angles = steering.as_doubles(static_cast<std::size_t>(n), Bound::closed(-kPi, kPi));
      for (int i = 0; i < n; ++i) (*state)[6 + i] = angles[static_cast<std::size_t>(i)];
    }
  }
}

// One entry of `controllers:`: its name (a plain word, none of the `earlier` entries'), its config
// file beside the scenario's, and the overrides a wear_mpc entry may carry (wear_weight, backend).
// With announce_friction, each patch's grip is told to the controllers each period: it must be one
// an estimating controller accepts (Controller::set_friction_scale), or the run would stop there.
void check_announced_grips(const ConfigNode& node, const ScenarioConfig& s) {
  if (!s.simulator.announce_friction) return;
  for (std::size_t p = 0; p < s.simulator.friction_patches.size(); ++p) {
    const double scale = s.simulator.friction_patches[p].mu / s.vehicle.tire.mu;
    for (const ScenarioController& c : s.controllers) {
      const FrictionEstimationOptions& estimation = c.config.mpc.friction_estimation;
      if (c.config.kind == ControllerKind::kWearMpc && estimation.enabled &&
          (scale < estimation.min_scale || scale > estimation.max_scale)) {
        node.child("simulator").child("friction_patches").at(p).fail_at(
            "mu", "= " + format(s.simulator.friction_patches[p].mu) + ": announced, it is " + format(scale) +
                      "x the tire's mu, outside controller '" + c.name + "''s friction_estimation bounds [" +
                      format(estimation.min_scale) + ", " + format(estimation.max_scale) + "]");
      }
    }
  }
}

ScenarioController load_scenario_controller(const ConfigNode& entry, const std::string& scenario_file,
                                            const std::vector<ScenarioController>& earlier) {
  ScenarioController c;
  c.name = entry.get_string("name");
  // The name becomes a file name (<out>/<name>.csv) and a JSON key: keep it to a plain word.
  if (c.name.empty() || c.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                            std::string::npos) {
    entry.fail_at("name", "'" + printable_value(c.name) + "': use letters, digits, '_' and '-' only");
  }
  for (const ScenarioController& other : earlier) {
    if (other.name == c.name) entry.fail_at("name", "'" + printable_value(c.name) + "' appears twice");
  }
  c.config_file = resolve_beside(scenario_file, entry.get_string("config"));
  try {
    c.config = load_controller_config_file(c.config_file);
  } catch (const ConfigError& error) {
    entry.fail_at("config", std::string("cannot load: ") + error.what());
  }
  c.config.name = c.name;
  if (entry.has("wear_weight")) {
    if (c.config.kind != ControllerKind::kWearMpc) entry.fail_at("wear_weight", "only a wear_mpc controller has one");
    c.config.mpc.wear_weight = entry.get_double("wear_weight", Bound::non_negative());
  }
  if (const auto friction = entry.optional_child("friction_estimation")) {
    if (c.config.kind != ControllerKind::kWearMpc) entry.fail_at("friction_estimation", "only a wear_mpc controller has one");
    config::read_fields(*friction, FrictionEstimationOptions::fields(), &c.config.mpc.friction_estimation);
  }
  if (const auto balancing = entry.optional_child("wear_balancing")) {
    if (c.config.kind != ControllerKind::kWearMpc) entry.fail_at("wear_balancing", "only a wear_mpc controller has one");
    config::read_fields(*balancing, WearBalancingOptions::fields(), &c.config.mpc.wear_balancing);
  }
  if (entry.has("backend")) {
    if (c.config.kind != ControllerKind::kWearMpc) entry.fail_at("backend", "only a wear_mpc controller has one");
    c.config.solver.backend = entry.get_string("backend");
    try {
      c.config.solver.validate();
    } catch (const ConfigError& error) {
      entry.fail_at("backend", error.what());
    }
  }
  return c;
}

}  // namespace

int ScenarioConfig::steps() const {
  const int count = step_count(duration, simulator.control_period);
  if (count < 0) throw_invalid_field("ScenarioConfig", "duration", duration, step_limit_rule(simulator.control_period));
  return count;
}

ScenarioConfig load_scenario_config(const ConfigNode& node) {
  const std::string& file_path = node.source();
  const std::string vehicle_file = resolve_beside(file_path, node.get_string("vehicle"));
  VehicleParams vehicle = [&] {
    try {
      return load_vehicle_config_file(vehicle_file);
    } catch (const ConfigError& error) {
      node.fail_at("vehicle", std::string("cannot load: ") + error.what());
    }
  }();
  ScenarioConfig s(std::move(vehicle));
  s.file = file_path;
  s.vehicle_file = vehicle_file;
  s.name = node.get_string("name");
  s.description = node.get_string_or("description", "");
  s.reference = load_reference(node.child("reference"), file_path, s.vehicle.layout.limits().max_drive_speed,
                               s.vehicle.layout.size(), &s.reference_description);
  // By default the run lasts as long as the reference moves: a constant-speed reference that ends
  // holds its final pose, and the step stop that asks for is not part of the paper's experiments
  // (it added up to 28 J to a 47 J curve run, more than the whole path did to the baseline).
  s.duration = node.get_double_or("duration", s.reference->duration(), Bound::positive());

  const int n = s.vehicle.layout.size();
  const ReferenceSample start = s.reference->sample(0.0);
  s.initial_state = Eigen::VectorXd::Zero(6 + n);
  s.initial_state.head<3>() = start.pose_world;
  if (const auto initial = node.optional_child("initial_state")) read_initial_state(*initial, n, &s.initial_state);

  if (const auto sim = node.optional_child("simulator")) {
    config::read_fields(*sim, SimulatorOptions::fields(), &s.simulator);
    s.simulator.seed = static_cast<std::uint64_t>(sim->get_int_or("seed", 1, 0));
    if (const auto noise = sim->optional_child("noise")) {
      config::read_fields(*noise, MeasurementNoise::fields(), &s.simulator.noise);
    }
    if (const auto faults = sim->optional_child("faults")) s.simulator.faults = load_plant_faults(*faults, n);
    if (const auto patches = sim->optional_child("friction_patches")) {
      s.simulator.friction_patches = load_friction_patches(*patches);
    }
    s.simulator.announce_friction = sim->get_bool_or("announce_friction", false);
    if (sim->has("initial_module_wear")) {
      s.simulator.initial_module_wear =
          sim->get_doubles("initial_module_wear", static_cast<std::size_t>(n), Bound::non_negative());
    }
  }

  const ConfigNode controllers = node.child("controllers");
  if (!controllers.is_sequence() || controllers.size() == 0) controllers.fail("expected a list of >= 1 controllers");
  for (std::size_t j = 0; j < controllers.size(); ++j) {
    const ConfigNode entry = controllers.at(j);
    ScenarioController c = load_scenario_controller(entry, file_path, s.controllers);
    s.controllers.push_back(std::move(c));
  }
  // The vehicle's state observer, the same in front of every controller: a comparison in which one
  // controller filters the sensor noise and the other does not would compare the filters.
  if (const auto filter = node.optional_child("measurement_filter")) {
    const MeasurementFilterOptions options = load_measurement_filter(*filter, MeasurementFilterOptions{});
    for (ScenarioController& c : s.controllers) c.config.set_measurement_filter(options);
  }
  s.simulator.control_period = s.controllers.front().config.period();
  for (const ScenarioController& c : s.controllers) {
    if (std::abs(c.config.period() - s.simulator.control_period) > 1e-12) {
      controllers.fail("controller '" + c.name + "' has a control period of " + format(c.config.period()) + " s but '" +
                       s.controllers.front().name + "' has " + format(s.simulator.control_period) +
                       ": all controllers of a scenario share the control period");
    }
  }
  if (step_count(s.duration, s.simulator.control_period) < 0) {
    const std::string rule = ": " + step_limit_rule(s.simulator.control_period);
    if (node.has("duration")) node.fail_at("duration", "= " + node.child("duration").to_yaml() + rule);
    node.fail_at("duration", "= " + format(s.duration) + " (the reference's duration)" + rule);
  }
  // A fault is in the run only if a control period starts at or after it.
  const double last_start = (s.steps() - 1) * s.simulator.control_period;
  for (std::size_t f = 0; f < s.simulator.faults.size(); ++f) {
    if (!s.simulator.faults[f].due_by(last_start)) {
      const config::ConfigNode at = node.child("simulator").child("faults").at(f).child("at");
      at.fail("= " + at.to_yaml() + ": no control period starts at or after it (the last starts at " +
              format(last_start) + " s)");
    }
  }
  check_announced_grips(node, s);
  if (const auto paper = node.optional_child("paper")) {
    s.paper_wear_reduction_pct = paper->get_double("wear_reduction_pct");
  }
  s.simulator.validate();
  // Build what `run` builds (see the header): a rule only a constructor knows names this file.
  try {
    const Simulator plant(s.vehicle, s.simulator);
  } catch (const ConfigError& error) {
    node.fail_at("simulator", error.what());
  }
  for (std::size_t j = 0; j < s.controllers.size(); ++j) {
    try {
      (void)make_controller(s.controllers[j].config, s.vehicle, s.reference);
    } catch (const ConfigError& error) {
      controllers.at(j).fail(error.what());
    }
  }
  return s;
}

ScenarioConfig load_scenario_config_file(const std::string& file_path) {
  const ConfigNode root = ConfigNode::load_file(file_path);
  ScenarioConfig s = load_scenario_config(root.child("scenario"));
  root.expect_all_read();
  return s;
}

}  // namespace swerve
