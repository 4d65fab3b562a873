#include "swerve/app/kinematics_config.hpp"

#include <Eigen/Core>
#include <string>
#include <vector>

#include "swerve/app/option_reader.hpp"
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
    config::read_fields(*node, ModuleLimits::fields(), &limits);
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
  KinematicsOptions options;
  config::read_fields(node, KinematicsOptions::fields(), &options);
  options.validate();
  return options;
}

}  // namespace swerve
