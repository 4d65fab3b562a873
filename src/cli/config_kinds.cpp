#include "config_kinds.hpp"

#include "swerve/app/controller_config.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/app/vehicle_config.hpp"

namespace swerve::cli {
namespace {

nlohmann::json load_target(const config::ConfigNode& section) {
  const TargetConfig target = load_target_config(section);
  return {{"name", target.name},
          {"description", target.description},
          {"control_period_s", target.control_period},
          {"solve_budget_s", target.solve_budget},
          {"cores", target.cores},
          {"cpu_slowdown", target.cpu_slowdown}};
}

nlohmann::json load_vehicle(const config::ConfigNode& section) {
  const VehicleParams vehicle = load_vehicle_config(section);
  nlohmann::json modules = nlohmann::json::array();
  for (const Eigen::Vector2d& p : vehicle.layout.positions_body()) modules.push_back({p.x(), p.y()});
  nlohmann::json casters = nlohmann::json::array();
  for (const CasterParams& c : vehicle.casters) {
    casters.push_back({{"position_m", {c.position_body.x(), c.position_body.y()}},
                       {"rolling_resistance", c.rolling_resistance}});
  }
  const ModuleLimits& limits = vehicle.layout.limits();
  return {{"name", vehicle.name},
          {"mass_kg", vehicle.mass},
          {"yaw_inertia_kg_m2", vehicle.yaw_inertia},
          {"center_of_mass_m", {vehicle.center_of_mass_body.x(), vehicle.center_of_mass_body.y()}},
          {"cog_height_m", vehicle.cog_height ? nlohmann::json(*vehicle.cog_height) : nlohmann::json(nullptr)},
          {"wheel_radius_m", vehicle.layout.wheel_radius()},
          {"module_positions_m", modules},
          {"casters", casters},
          {"static_normal_loads_n", vehicle.static_normal_loads()},
          {"limits",
           {{"drive_speed_m_s", limits.max_drive_speed},
            {"drive_acceleration_m_s2", limits.max_drive_acceleration},
            {"steering_rate_rad_s", limits.max_steering_rate},
            {"steering_angle_rad", {limits.min_steering_angle, limits.max_steering_angle}}}},
          {"actuators",
           {{"steering_time_constant_s", vehicle.actuators.steering_time_constant},
            {"drive_time_constant_s", vehicle.actuators.drive_time_constant}}},
          {"tire",
           {{"mu", vehicle.tire.mu},
            {"mu_longitudinal", vehicle.tire.mu_longitudinal()},
            {"mu_lateral", vehicle.tire.mu_lateral()},
            {"longitudinal", {{"B", vehicle.tire.longitudinal.b}, {"C", vehicle.tire.longitudinal.c},
                              {"E", vehicle.tire.longitudinal.e},
                              {"peak_slip", magic_formula_peak_slip(vehicle.tire.longitudinal)}}},
            {"lateral", {{"B", vehicle.tire.lateral.b}, {"C", vehicle.tire.lateral.c}, {"E", vehicle.tire.lateral.e},
                         {"peak_slip_rad", magic_formula_peak_slip(vehicle.tire.lateral)}}},
            {"combined_slip", to_string(vehicle.tire.combined_slip)},
            {"slip_speed_epsilon_m_s", vehicle.tire.slip_speed_epsilon},
            {"smooth_slip", vehicle.tire.smooth_slip}}},
          {"wear",
           {{"model", to_string(vehicle.wear.model)},
            {"coefficient", vehicle.wear.coefficient},
            {"smoothing", vehicle.wear.smoothing}}},
          {"plant",
           {{"actuator_lag", vehicle.plant.actuator_lag},
            {"actuator_saturation", vehicle.plant.actuator_saturation},
            {"relaxation_length_m", vehicle.plant.relaxation_length},
            {"load_transfer", vehicle.plant.load_transfer}}}};
}

nlohmann::json controller_json(const ControllerConfig& c) {
  nlohmann::json j = {{"name", c.name}, {"type", to_string(c.kind)}, {"horizon", c.baseline.horizon},
                      {"dt_s", c.baseline.dt}};
  const BaselineOptions& b = c.baseline;
  j["baseline"] = {{"pose_weight", {b.pose_weight.x(), b.pose_weight.y(), b.pose_weight.z()}},
                   {"twist_weight", {b.twist_weight.x(), b.twist_weight.y(), b.twist_weight.z()}},
                   {"rate_weight", {b.rate_weight.x(), b.rate_weight.y(), b.rate_weight.z()}},
                   {"terminal_scale", b.terminal_scale},
                   {"gauss_newton_iterations", b.gauss_newton_iterations},
                   {"cosine_scaling", b.cosine_scaling},
                   {"flip_hysteresis_rad", b.flip_hysteresis},
                   {"steer_speed_threshold_m_per_s", b.steer_speed_threshold}};
  j["measurement_filter"] = {{"pose_gain", b.measurement_filter.pose_gain},
                             {"steering_gain", b.measurement_filter.steering_gain}};
  if (c.kind != ControllerKind::kWearMpc) return j;
  const ControllerOptions& o = c.mpc;
  j["solve_budget_s"] = o.solve_budget;
  j["overrun_grace_s"] = o.overrun_grace;
  j["deadline_margin"] = o.deadline_margin;
  j["baseline_guess"] = o.baseline_guess;
  j["inputs"] = to_string(o.parameterization);
  j["max_plan_age"] = o.max_plan_age;
  if (o.tracking_tolerance.enabled()) {
    j["tracking_tolerance"] = {{"position_m", o.tracking_tolerance.position},
                               {"heading_rad", o.tracking_tolerance.heading},
                               {"penalty", o.tracking_tolerance.penalty}};
  } else {
    j["tracking_tolerance"] = nullptr;
  }
  j["weights"] = {{"pose", {o.pose_weight.x(), o.pose_weight.y(), o.pose_weight.z()}},
                  {"twist", {o.twist_weight.x(), o.twist_weight.y(), o.twist_weight.z()}},
                  {"terminal_scale", o.terminal_scale},
                  {"pose_huber_width", o.pose_huber_width},
                  {"wear", o.wear_weight},
                  {"wear_reference_mass", o.wear_reference_mass},
                  {"wear_mass_exponent", o.wear_mass_exponent},
                  {"steering_rate_effort", o.steering_rate_effort},
                  {"wheel_speed_effort", o.wheel_speed_effort},
                  {"steering_rate_smoothness", o.steering_rate_smoothness},
                  {"wheel_speed_smoothness", o.wheel_speed_smoothness},
                  {"twist_smoothness", o.twist_smoothness},
                  {"steering_effort", o.steering_effort},
                  {"heading_from_geometry", o.heading_weight_from_geometry},
                  {"heading_lever", o.heading_lever}};
  j["prediction"] = {{"method", to_string(o.prediction.method)},
                     {"substeps", o.prediction.substeps},
                     {"slow_substeps", o.prediction.slow_substeps},
                     {"drive_lag", o.prediction.drive_lag},
                     {"steering_lag", o.prediction.steering_lag},
                     {"max_newton_iterations", o.prediction.max_newton_iterations}};
  const SaOptions& sa = c.solver.sa;
  j["solver"] = {{"backend", c.solver.backend},
                 {"sa",
                  {{"knots", sa.knots},
                   {"max_iterations", sa.max_iterations},
                   {"initial_acceptance", sa.initial_acceptance},
                   {"final_temperature_ratio", sa.final_temperature_ratio},
                   {"step_fraction", sa.step_fraction},
                   {"target_acceptance", sa.target_acceptance},
                   {"adapt_interval", sa.adapt_interval},
                   {"reheat_interval", sa.reheat_interval},
                   {"probability_one_group", sa.probability_one_group},
                   {"probability_one_knot", sa.probability_one_knot},
                   {"polish_share", sa.polish_share},
                   {"polish_iterations", sa.polish_iterations},
                   {"knot_polish", sa.knot_polish},
                   {"threads", sa.threads},
                   {"seed", sa.seed}}},
                 {"rti",
                  {{"max_iterations", c.solver.rti.max_iterations},
                   {"tolerance", c.solver.rti.tolerance},
                   {"qp_tolerance", c.solver.rti.qp_tolerance},
                   {"qp_max_iterations", c.solver.rti.qp_max_iterations},
                   {"line_search_steps", c.solver.rti.line_search_steps},
                   {"damping", c.solver.rti.damping},
                   {"wear_curvature", c.solver.rti.wear_curvature},
                   {"stage_quasi_newton", c.solver.rti.stage_quasi_newton}}},
                 {"nlopt",
                  {{"algorithm", c.solver.nlopt.algorithm},
                   {"xtol_rel", c.solver.nlopt.xtol_rel},
                   {"ftol_rel", c.solver.nlopt.ftol_rel},
                   {"max_evaluations", c.solver.nlopt.max_evaluations},
                   {"initial_step_fraction", c.solver.nlopt.initial_step_fraction}}}};
  return j;
}

nlohmann::json load_controller(const config::ConfigNode& section) {
  return controller_json(load_controller_config(section));
}

nlohmann::json load_scenario(const config::ConfigNode& section) {
  const ScenarioConfig s = load_scenario_config(section);
  nlohmann::json controllers = nlohmann::json::array();
  for (const ScenarioController& c : s.controllers) {
    nlohmann::json entry = controller_json(c.config);
    entry["config_file"] = c.config_file;
    controllers.push_back(entry);
  }
  std::vector<double> initial(s.initial_state.data(), s.initial_state.data() + s.initial_state.size());
  return {{"name", s.name},
          {"description", s.description},
          {"vehicle_file", s.vehicle_file},
          {"vehicle", s.vehicle.name},
          {"reference", s.reference_description},
          {"duration_s", s.duration},
          {"initial_state", initial},
          {"control_period_s", s.simulator.control_period},
          {"simulator", {{"substeps", s.simulator.substeps}, {"seed", s.simulator.seed},
                         {"measurement_delay_steps", s.simulator.measurement_delay_steps}}},
          {"controllers", controllers},
          {"paper_wear_reduction_pct",
           s.paper_wear_reduction_pct ? nlohmann::json(*s.paper_wear_reduction_pct) : nlohmann::json()}};
}

}  // namespace

const std::vector<ConfigKind>& all_config_kinds() {
  static const std::vector<ConfigKind> kinds = {
      {"target", "an embedded target's real-time budget (configs/targets/)", &load_target},
      {"vehicle", "a vehicle: body, modules, tires, wear (configs/vehicles/)", &load_vehicle},
      {"controller", "a controller: wear-aware MPC or kinematic baseline (configs/controllers/)", &load_controller},
      {"scenario", "a closed-loop scenario: vehicle, reference, controllers (configs/scenarios/)", &load_scenario},
  };
  return kinds;
}

nlohmann::json load_any_config_file(const std::string& file_path) {
  const config::ConfigNode root = config::ConfigNode::load_file(file_path);
  nlohmann::json loaded = {{"file", file_path}};
  bool found_any = false;
  for (const ConfigKind& kind : all_config_kinds()) {
    if (const auto section = root.optional_child(kind.top_key)) {
      loaded[kind.top_key] = kind.load(*section);
      found_any = true;
    }
  }
  if (!found_any) {
    std::string expected;
    for (const ConfigKind& kind : all_config_kinds()) {
      expected += (expected.empty() ? "" : ", ") + kind.top_key;
    }
    root.fail("no known section at the top level (expected one of: " + expected + ")");
  }
  root.expect_all_read();
  return loaded;
}

}  // namespace swerve::cli
