#include "swerve/app/controller_config.hpp"

#include "swerve/app/vehicle_config.hpp"

namespace swerve {
namespace {

using config::Bound;
using config::ConfigNode;

Eigen::Vector3d get_vector3_or(const ConfigNode& node, const std::string& key, const Eigen::Vector3d& fallback) {
  if (!node.has(key)) return fallback;
  const std::vector<double> v = node.get_doubles(key, 3, Bound::non_negative());
  return {v[0], v[1], v[2]};
}

SaOptions load_sa(const ConfigNode& node) {
  SaOptions sa;
  sa.knots = node.get_int_or("knots", sa.knots, 0);
  sa.max_iterations = node.get_int_or("max_iterations", sa.max_iterations, 1);
  sa.initial_acceptance = node.get_double_or("initial_acceptance", sa.initial_acceptance, Bound{0, 1, true, true});
  sa.final_temperature_ratio =
      node.get_double_or("final_temperature_ratio", sa.final_temperature_ratio, Bound::half_open(0.0, 1.0));
  sa.step_fraction = node.get_double_or("step_fraction", sa.step_fraction, Bound::half_open(0.0, 1.0));
  sa.target_acceptance = node.get_double_or("target_acceptance", sa.target_acceptance, Bound{0, 1, true, true});
  sa.adapt_interval = node.get_int_or("adapt_interval", sa.adapt_interval, 1);
  sa.reheat_interval = node.get_int_or("reheat_interval", sa.reheat_interval, 0);
  sa.probability_one_group = node.get_double_or("probability_one_group", sa.probability_one_group, Bound::closed(0, 1));
  sa.probability_one_knot = node.get_double_or("probability_one_knot", sa.probability_one_knot, Bound::closed(0, 1));
  sa.seed = static_cast<std::uint64_t>(node.get_int_or("seed", static_cast<int>(sa.seed), 0));
  sa.polish_share = node.get_double_or("polish_share", sa.polish_share, Bound::right_open(0.0, 1.0));
  sa.polish_iterations = node.get_int_or("polish_iterations", sa.polish_iterations, 0);
  sa.knot_polish = node.get_bool_or("knot_polish", sa.knot_polish);
  sa.threads = node.get_int_or("threads", sa.threads, 1, 16);
  return sa;
}

BaselineOptions load_baseline(const ConfigNode& node, BaselineOptions b) {
  b.pose_weight = get_vector3_or(node, "pose_weight", b.pose_weight);
  b.twist_weight = get_vector3_or(node, "twist_weight", b.twist_weight);
  b.rate_weight = get_vector3_or(node, "rate_weight", b.rate_weight);
  b.terminal_scale = node.get_double_or("terminal_scale", b.terminal_scale, Bound::non_negative());
  b.gauss_newton_iterations = node.get_int_or("gauss_newton_iterations", b.gauss_newton_iterations, 1, 100);
  b.cosine_scaling = node.get_bool_or("cosine_scaling", b.cosine_scaling);
  b.flip_hysteresis = node.get_double_or("flip_hysteresis", b.flip_hysteresis, Bound::right_open(0.0, kPi / 2));
  b.steer_speed_threshold = node.get_double_or("steer_speed_threshold", b.steer_speed_threshold, Bound::non_negative());
  return b;
}

void load_weights(const ConfigNode& node, ControllerOptions* o) {
  o->pose_weight = get_vector3_or(node, "pose", o->pose_weight);
  o->twist_weight = get_vector3_or(node, "twist", o->twist_weight);
  o->terminal_scale = node.get_double_or("terminal_scale", o->terminal_scale, Bound::non_negative());
  o->pose_huber_width = node.get_double_or("pose_huber_width", o->pose_huber_width, Bound::non_negative());
  o->wear_weight = node.get_double_or("wear", o->wear_weight, Bound::non_negative());
  o->wear_reference_mass = node.get_double_or("wear_reference_mass", o->wear_reference_mass, Bound::non_negative());
  o->wear_mass_exponent = node.get_double_or("wear_mass_exponent", o->wear_mass_exponent, Bound::positive());
  if (node.has("wear_mass_exponent") && !(o->wear_reference_mass > 0.0)) {
    node.fail_at("wear_mass_exponent", "= " + std::to_string(o->wear_mass_exponent) +
                                           ": used only with wear_reference_mass > 0, which is not set here");
  }
  o->steering_rate_effort = node.get_double_or("steering_rate_effort", o->steering_rate_effort, Bound::non_negative());
  o->wheel_speed_effort = node.get_double_or("wheel_speed_effort", o->wheel_speed_effort, Bound::non_negative());
  o->steering_rate_smoothness =
      node.get_double_or("steering_rate_smoothness", o->steering_rate_smoothness, Bound::non_negative());
  o->wheel_speed_smoothness =
      node.get_double_or("wheel_speed_smoothness", o->wheel_speed_smoothness, Bound::non_negative());
  o->twist_smoothness = node.get_double_or("twist_smoothness", o->twist_smoothness, Bound::non_negative());
  o->heading_weight_from_geometry = node.get_bool_or("heading_from_geometry", o->heading_weight_from_geometry);
  o->heading_lever = node.get_double_or("heading_lever", o->heading_lever, Bound::positive());
  if (node.has("heading_lever") && !o->heading_weight_from_geometry) {
    node.fail_at("heading_lever", "= " + std::to_string(o->heading_lever) +
                                      ": used only with heading_from_geometry: true, which is not set here");
  }
}

}  // namespace

MeasurementFilterOptions load_measurement_filter(const ConfigNode& node, MeasurementFilterOptions f) {
  f.pose_gain = node.get_double_or("pose_gain", f.pose_gain, Bound::half_open(0.0, 1.0));
  f.steering_gain = node.get_double_or("steering_gain", f.steering_gain, Bound::half_open(0.0, 1.0));
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
  const int horizon = node.get_int_or("horizon", c.mpc.horizon, 1, kMaxHorizon);
  const double dt = node.get_double_or("dt", c.mpc.dt, Bound::positive());
  c.set_sampling(horizon, dt);
  if (c.kind == ControllerKind::kWearMpc) {
    c.mpc.solve_budget = node.get_double_or("solve_budget", c.mpc.solve_budget, Bound::positive());
    c.mpc.overrun_grace = node.get_double_or("overrun_grace", c.mpc.overrun_grace, Bound::non_negative());
    c.mpc.deadline_margin = node.get_double_or("deadline_margin", c.mpc.deadline_margin, Bound::closed(0.0, 0.5));
    c.mpc.baseline_guess = node.get_bool_or("baseline_guess", c.mpc.baseline_guess);
    c.mpc.max_plan_age = node.get_int_or("max_plan_age", c.mpc.max_plan_age, 0);
    if (const auto stale = node.optional_child("stale_measurement")) {
      StalenessOptions& o = c.mpc.stale_measurement;
      o.max_age = stale->get_double_or("max_age", o.max_age, Bound::positive());
      o.frozen_cycles = stale->get_int_or("frozen_cycles", o.frozen_cycles, 2, 1000000);
      o.moving_speed = stale->get_double_or("moving_speed", o.moving_speed, Bound::positive());
    }
    if (const auto tolerance = node.optional_child("tracking_tolerance")) {
      TrackingTolerance& o = c.mpc.tracking_tolerance;
      o.position = tolerance->get_double("position", Bound::positive());
      o.heading = tolerance->get_double("heading", Bound::positive());
      o.penalty = tolerance->get_double_or("penalty", o.penalty, Bound::positive());
    }
    if (const auto weights = node.optional_child("weights")) load_weights(*weights, &c.mpc);
    c.mpc.parameterization = node.get_choice_or("inputs", {"body_twist", "module_rates"}, "body_twist") == "module_rates"
                                 ? InputParameterization::kModuleRates
                                 : InputParameterization::kBodyTwist;
    if (const auto prediction = node.optional_child("prediction")) {
      const std::string method = prediction->get_choice_or("method", {"semi_implicit", "rk4"}, "semi_implicit");
      c.mpc.prediction.method = method == "rk4" ? PredictionMethod::kRk4 : PredictionMethod::kSemiImplicit;
      c.mpc.prediction.substeps = prediction->get_int_or("substeps", c.mpc.prediction.substeps, 1, 1000);
      c.mpc.prediction.slow_substeps = prediction->get_int_or("slow_substeps", c.mpc.prediction.slow_substeps, 1, 1000);
      c.mpc.prediction.drive_lag = prediction->get_bool_or("drive_lag", c.mpc.prediction.drive_lag);
      c.mpc.prediction.steering_lag = prediction->get_bool_or("steering_lag", c.mpc.prediction.steering_lag);
      c.mpc.prediction.max_newton_iterations =
          prediction->get_int_or("max_newton_iterations", c.mpc.prediction.max_newton_iterations, 1, 100);
    }
    if (const auto solver = node.optional_child("solver")) {
      c.solver.backend = solver->get_choice_or("backend", {"sa", "ipopt", "nlopt", "ceres"}, "sa");
      if (const auto sa = solver->optional_child("sa")) c.solver.sa = load_sa(*sa);
      if (const auto nlopt = solver->optional_child("nlopt")) {
        NloptOptions& o = c.solver.nlopt;
        o.algorithm = nlopt->get_string_or("algorithm", o.algorithm);
        o.xtol_rel = nlopt->get_double_or("xtol_rel", o.xtol_rel, Bound::non_negative());
        o.ftol_rel = nlopt->get_double_or("ftol_rel", o.ftol_rel, Bound::non_negative());
        o.max_evaluations = nlopt->get_int_or("max_evaluations", o.max_evaluations, 1);
        o.initial_step_fraction =
            nlopt->get_double_or("initial_step_fraction", o.initial_step_fraction, Bound::half_open(0.0, 1.0));
      }
      if (const auto ipopt = solver->optional_child("ipopt")) {
        IpoptOptions& o = c.solver.ipopt;
        o.tol = ipopt->get_double_or("tol", o.tol, Bound::positive());
        o.constr_viol_tol = ipopt->get_double_or("constr_viol_tol", o.constr_viol_tol, Bound::positive());
        o.acceptable_tol = ipopt->get_double_or("acceptable_tol", o.acceptable_tol, Bound::positive());
        o.max_iterations = ipopt->get_int_or("max_iterations", o.max_iterations, 1);
        o.mu_strategy = ipopt->get_choice_or("mu_strategy", {"adaptive", "monotone"}, o.mu_strategy);
        o.linear_solver = ipopt->get_choice_or("linear_solver", {"mumps"}, o.linear_solver);
        o.print_level = ipopt->get_int_or("print_level", o.print_level, 0, 12);
        o.hessian = ipopt->get_choice_or("hessian", {"exact", "limited-memory"}, o.hessian);
        o.lbfgs_history = ipopt->get_int_or("lbfgs_history", o.lbfgs_history, 1, 100);
        o.warm_start = ipopt->get_bool_or("warm_start", o.warm_start);
        o.warm_start_multipliers = ipopt->get_bool_or("warm_start_multipliers", o.warm_start_multipliers);
        o.warm_mu_init = ipopt->get_double_or("warm_mu_init", o.warm_mu_init, Bound::positive());
        o.startup_estimate = ipopt->get_double_or("startup_estimate", o.startup_estimate, Bound::non_negative());
      }
      if (const auto ceres = solver->optional_child("ceres")) {
        CeresOptions& o = c.solver.ceres;
        o.max_iterations = ceres->get_int_or("max_iterations", o.max_iterations, 1);
        o.function_tolerance = ceres->get_double_or("function_tolerance", o.function_tolerance, Bound::positive());
        o.gradient_tolerance = ceres->get_double_or("gradient_tolerance", o.gradient_tolerance, Bound::positive());
        o.parameter_tolerance = ceres->get_double_or("parameter_tolerance", o.parameter_tolerance, Bound::positive());
        o.linear_solver =
            ceres->get_choice_or("linear_solver", {"dense_qr", "dense_normal_cholesky"}, o.linear_solver);
        o.step_penalty_weight = ceres->get_double_or("step_penalty_weight", o.step_penalty_weight, Bound::non_negative());
      }
      try {
        c.solver.validate();
      } catch (const ConfigError& error) {
        solver->fail_at("backend", error.what());
      }
    }
    if (c.mpc.solve_budget > dt) {
      node.fail_at("solve_budget", "= " + std::to_string(c.mpc.solve_budget) + ": must not exceed dt (" +
                                       std::to_string(dt) + "), the controller's period");
    }
  }
  if (const auto baseline = node.optional_child("baseline")) c.baseline = load_baseline(*baseline, c.baseline);
  if (const auto filter = node.optional_child("measurement_filter")) {
    c.set_measurement_filter(load_measurement_filter(*filter, c.mpc.measurement_filter));
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
                                                    std::shared_ptr<const Reference> reference) {
  config.validate();
  if (config.kind == ControllerKind::kKinematicBaseline) {
    return std::make_unique<KinematicBaseline>(vehicle.layout, std::move(reference), config.baseline);
  }
  const SolverConfig solver = config.solver;
  return std::make_unique<Controller>(
      vehicle, std::move(reference), config.mpc,
      [solver](const OcpProblem& problem) { return make_solver(solver, problem); }, config.baseline,
      config.name.empty() ? "wear_mpc" : config.name);
}

std::unique_ptr<TrackingController> make_controller(const std::string& vehicle_yaml, const std::string& controller_yaml,
                                                    std::shared_ptr<const Reference> reference) {
  const VehicleParams vehicle = load_vehicle_config_file(vehicle_yaml);
  return make_controller(load_controller_config_file(controller_yaml), vehicle, std::move(reference));
}

}  // namespace swerve
