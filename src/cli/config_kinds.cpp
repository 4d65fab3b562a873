#include "config_kinds.hpp"

#include "swerve/config/target_config.hpp"
#include "swerve/config/vehicle_config.hpp"

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

}  // namespace

const std::vector<ConfigKind>& all_config_kinds() {
  static const std::vector<ConfigKind> kinds = {
      {"target", "an embedded target's real-time budget (configs/targets/)", &load_target},
      {"vehicle", "a vehicle: body, modules, tires, wear (configs/vehicles/)", &load_vehicle},
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
