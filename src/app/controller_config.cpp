#include "swerve/app/controller_config.hpp"

#include "swerve/app/option_reader.hpp"
#include "swerve/app/vehicle_config.hpp"

namespace swerve {
namespace {

using config::ConfigNode;
using config::read_fields;

SaOptions load_sa(const ConfigNode& node) {
  SaOptions sa;
  read_fields(node, SaOptions::fields(), &sa);
  sa.seed = static_cast<std::uint64_t>(node.get_int_or("seed", static_cast<int>(sa.seed), 0));
  return sa;
}

BaselineOptions load_baseline(const ConfigNode& node, BaselineOptions b) {
  read_fields(node, BaselineOptions::fields(), &b);
  return b;
}

void load_weights(const ConfigNode& node, ControllerOptions* o) {
  read_fields(node, ControllerOptions::weight_fields(), o);
  if (node.has("wear_mass_exponent") && !(o->wear_reference_mass > 0.0)) {
    node.fail_at("wear_mass_exponent", "= " + std::to_string(o->wear_mass_exponent) +
                                           ": used only with wear_reference_mass > 0, which is not set here");
  }
  if (node.has("heading_lever") && !o->heading_weight_from_geometry) {
    node.fail_at("heading_lever", "= " + std::to_string(o->heading_lever) +
                                      ": used only with heading_from_geometry: true, which is not set here");
  }
}

}  // namespace

MeasurementFilterOptions load_measurement_filter(const ConfigNode& node, MeasurementFilterOptions f) {
  read_fields(node, MeasurementFilterOptions::fields(), &f);
  return f;
}

void ControllerConfig::set_measurement_filter(const MeasurementFilterOptions& filter) {
  mpc.measurement_filter = baseline.measurement_filter = filter;
}

void ControllerConfig::set_sampling(int horizon, double dt) {
  mpc.horizon = baseline.horizon = horizon;
  mpc.dt = baseline.dt = dt;
}

const char* to_string(ControllerKind kind) noexcept {
  return kind == ControllerKind::kWearMpc ? "wear_mpc" : "kinematic_baseline";
}

void ControllerConfig::validate() const {
  baseline.validate();
  if (kind == ControllerKind::kWearMpc) {
    mpc.validate();
    solver.validate();
  }
}

ControllerConfig load_controller_config(const ConfigNode& node) {
  ControllerConfig c;
  c.name = node.get_string("name");
  (void)node.get_string_or("description", "");
  c.kind = node.get_choice("type", {"wear_mpc", "kinematic_baseline"}) == "wear_mpc" ? ControllerKind::kWearMpc
                                                                                      : ControllerKind::kKinematicBaseline;
  ControllerOptions sampling = c.mpc;
  read_fields(node, ControllerOptions::sampling_fields(), &sampling);
  c.set_sampling(sampling.horizon, sampling.dt);
  const double dt = sampling.dt;
  if (c.kind == ControllerKind::kWearMpc) {
    read_fields(node, ControllerOptions::timing_fields(), &c.mpc);
    if (const auto stale = node.optional_child("stale_measurement")) {
      read_fields(*stale, StalenessOptions::fields(), &c.mpc.stale_measurement);
    }
    if (const auto work = node.optional_child("work_budget")) {
      read_fields(*work, WorkBudgetOptions::fields(), &c.mpc.work_budget);
    }
    if (const auto tolerance = node.optional_child("tracking_tolerance")) {
      (void)tolerance->child("position");  // both required: a tolerance block without one is a mistake
      (void)tolerance->child("heading");
      read_fields(*tolerance, TrackingTolerance::fields(), &c.mpc.tracking_tolerance);
    }
    if (const auto weights = node.optional_child("weights")) load_weights(*weights, &c.mpc);
    c.mpc.parameterization = node.get_choice_or("inputs", {"body_twist", "module_rates"}, "body_twist") == "module_rates"
                                 ? InputParameterization::kModuleRates
                                 : InputParameterization::kBodyTwist;
    if (const auto prediction = node.optional_child("prediction")) {
      const std::string method = prediction->get_choice_or("method", {"semi_implicit", "rk4"}, "semi_implicit");
      c.mpc.prediction.method = method == "rk4" ? PredictionMethod::kRk4 : PredictionMethod::kSemiImplicit;
      read_fields(*prediction, PredictionOptions::fields(), &c.mpc.prediction);
    }
    if (const auto friction = node.optional_child("friction_estimation")) {
      read_fields(*friction, FrictionEstimationOptions::fields(), &c.mpc.friction_estimation);
    }
    if (const auto balancing = node.optional_child("wear_balancing")) {
      read_fields(*balancing, WearBalancingOptions::fields(), &c.mpc.wear_balancing);
    }
    if (const auto solver = node.optional_child("solver")) {
      c.solver.backend = solver->get_choice_or("backend", {"sa", "rti", "ipopt", "nlopt", "ceres"}, "sa");
      if (const auto sa = solver->optional_child("sa")) c.solver.sa = load_sa(*sa);
      if (const auto rti = solver->optional_child("rti")) read_fields(*rti, RtiOptions::fields(), &c.solver.rti);
      if (const auto nlopt = solver->optional_child("nlopt")) read_fields(*nlopt, NloptOptions::fields(), &c.solver.nlopt);
      if (const auto ipopt = solver->optional_child("ipopt")) read_fields(*ipopt, IpoptOptions::fields(), &c.solver.ipopt);
      if (const auto ceres = solver->optional_child("ceres")) read_fields(*ceres, CeresOptions::fields(), &c.solver.ceres);
      try {
        c.solver.validate();
      } catch (const ConfigError& error) {
        solver->fail_at("backend", error.what());
      }
    }
    if (c.mpc.control_period > dt) {
      node.fail_at("control_period", "= " + std::to_string(c.mpc.control_period) + ": must not exceed dt (" +
                                         std::to_string(dt) + "): a cycle must not skip a prediction step");
    }
    if (c.mpc.solve_budget > c.mpc.period()) {
      node.fail_at("solve_budget", "= " + std::to_string(c.mpc.solve_budget) + ": must not exceed " +
                                       (c.mpc.control_period > 0.0 ? "control_period (" : "dt (") +
                                       std::to_string(c.mpc.period()) + "), the controller's period");
    }
  }
  if (const auto baseline = node.optional_child("baseline")) c.baseline = load_baseline(*baseline, c.baseline);
  if (const auto filter = node.optional_child("measurement_filter")) {
    c.set_measurement_filter(load_measurement_filter(*filter, c.mpc.measurement_filter));
  }
  // The stuck-steering detector, for either kind (the wear-aware controller's baseline runs none).
  if (const auto detection = node.optional_child("fault_detection")) {
    read_fields(*detection, FaultDetectionOptions::fields(), &c.mpc.fault_detection);
    c.baseline.fault_detection = c.mpc.fault_detection;
  }
  try {
    c.validate();
  } catch (const ConfigError& error) {
    node.fail(error.what());
  }
  return c;
}

ControllerConfig load_controller_config_file(const std::string& file_path) {
  const ConfigNode root = ConfigNode::load_file(file_path);
  ControllerConfig c = load_controller_config(root.child("controller"));
  root.expect_all_read();
  return c;
}

std::unique_ptr<TrackingController> make_controller(const ControllerConfig& config, const VehicleParams& vehicle,
                                                    std::shared_ptr<const Reference> reference,
                                                    const BackendFactory& solvers) {
  if (!solvers) {
    throw ConfigError("make_controller: solvers is empty: pass swerve::make_core_solver, swerve::make_solver or a "
                      "factory of your own");
  }
  config.validate();
  if (config.kind == ControllerKind::kKinematicBaseline) {
    return std::make_unique<KinematicBaseline>(vehicle.layout, std::move(reference), config.baseline,
                                               ActuatorLags::of(vehicle));
  }
  const SolverConfig solver = config.solver;
  return std::make_unique<Controller>(
      vehicle, std::move(reference), config.mpc,
      [solver, solvers](const OcpProblem& problem) { return solvers(solver, problem); }, config.baseline,
      config.name.empty() ? "wear_mpc" : config.name);
}

std::unique_ptr<TrackingController> make_controller(const std::string& vehicle_yaml, const std::string& controller_yaml,
                                                    std::shared_ptr<const Reference> reference,
                                                    const BackendFactory& solvers) {
  const VehicleParams vehicle = load_vehicle_config_file(vehicle_yaml);
  return make_controller(load_controller_config_file(controller_yaml), vehicle, std::move(reference), solvers);
}

}  // namespace swerve
