#include "swerve/app/kinematics_config.hpp"

#include <Eigen/Core>
#include <string>
#include <vector>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

ModuleLayout load_module_layout(const config::ConfigNode& vehicle) {
  using config::Bound;
  const double wheel_radius = vehicle.get_double("wheel_radius", Bound::positive());
  const config::ConfigNode modules = vehicle.child("modules");
  if (modules.size() < 2) modules.fail("= " + modules.to_yaml() + ": need at least 2 modules");
  if (modules.size() > static_cast<std::size_t>(kMaxModules)) {
    modules.fail("= a list of " + std::to_string(modules.size()) + ": at most " + std::to_string(kMaxModules) +
                 " modules are supported");
  }
  std::vector<Eigen::Vector2d> positions;
  for (std::size_t i = 0; i < modules.size(); ++i) {
    const config::ConfigNode module = modules.at(i);
    const std::vector<double> xy = module.get_doubles("position", 2);
    const Eigen::Vector2d position(xy[0], xy[1]);
    for (std::size_t j = 0; j < positions.size(); ++j) {
      if ((position - positions[j]).norm() < kMinModuleSeparation) {
        module.fail_at("position", "= " + module.child("position").to_yaml() + ": coincides with modules[" +
                                       std::to_string(j) + "]");
      }
    }
    positions.push_back(position);
  }
  ModuleLimits limits;
  if (const auto node = vehicle.optional_child("limits")) {
    limits.max_drive_speed = node->get_double_or("drive_speed", limits.max_drive_speed, Bound::positive());
    limits.max_drive_acceleration =
        node->get_double_or("drive_acceleration", limits.max_drive_acceleration, Bound::positive());
    limits.max_steering_rate = node->get_double_or("steering_rate", limits.max_steering_rate, Bound::positive());
    if (const auto angle = node->optional_child("steering_angle")) {
      const std::vector<double> range = angle->as_doubles(2, Bound::closed(-kPi, kPi));
      if (range[0] >= range[1]) angle->fail("= " + angle->to_yaml() + ": min must be < max");
      limits.min_steering_angle = range[0];
      limits.max_steering_angle = range[1];
    }
  }
  try {
    return ModuleLayout(std::move(positions), wheel_radius, limits);
  } catch (const ConfigError& error) {
    vehicle.fail(error.what());  // keep the file and path in front of the geometric rule
  }
}

KinematicsOptions load_kinematics_options(const config::ConfigNode& node) {
  using config::Bound;
  KinematicsOptions options;
  options.hold_speed_threshold =
      node.get_double_or("hold_speed_threshold", options.hold_speed_threshold, Bound::positive());
  options.flip_hysteresis = node.get_double_or("flip_hysteresis", options.flip_hysteresis,
                                               Bound{0.0, kPi / 2.0, false, true});
  options.whole_robot_flip = node.get_bool_or("whole_robot_flip", options.whole_robot_flip);
  options.cosine_scaling = node.get_bool_or("cosine_scaling", options.cosine_scaling);
  options.validate();
  return options;
}

}  // namespace swerve
