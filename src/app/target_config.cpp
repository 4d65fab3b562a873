#include "swerve/app/target_config.hpp"

#include <cmath>
#include <sstream>

namespace swerve {

void TargetConfig::validate() const {
  auto require = [](bool ok, const char* field, double value, const char* rule) {
    if (!ok) {
      std::ostringstream message;
      message << "TargetConfig." << field << " = " << value << ": " << rule;
      throw ConfigError(message.str());
    }
  };
  require(std::isfinite(control_period) && control_period > 0, "control_period", control_period, "must be > 0");
  require(std::isfinite(solve_budget) && solve_budget > 0, "solve_budget", solve_budget, "must be > 0");
  require(solve_budget <= control_period, "solve_budget", solve_budget,
          "must not exceed control_period (a solve must finish within its cycle)");
  require(cores >= 1, "cores", cores, "must be >= 1");
  require(std::isfinite(cpu_slowdown) && cpu_slowdown > 0, "cpu_slowdown", cpu_slowdown, "must be > 0");
}

TargetConfig load_target_config(const config::ConfigNode& node) {
  using config::Bound;
  TargetConfig target;
  target.name = node.get_string("name");
  target.description = node.get_string_or("description", "");
  target.control_period = node.get_double("control_period", Bound::positive());
  target.solve_budget = node.get_double("solve_budget", Bound::positive());
  if (target.solve_budget > target.control_period) {
    node.fail_at("solve_budget", "= " + std::to_string(target.solve_budget) +
                                     ": must not exceed control_period (" +
                                     std::to_string(target.control_period) + ")");
  }
  target.cores = node.get_int_or("cores", 1, 1, 1024);
  target.cpu_slowdown = node.get_double_or("cpu_slowdown", 1.0, Bound::positive());
  target.validate();
  return target;
}

TargetConfig load_target_config_file(const std::string& file_path) {
  const config::ConfigNode root = config::ConfigNode::load_file(file_path);
  TargetConfig target = load_target_config(root.child("target"));
  root.expect_all_read();
  return target;
}

}  // namespace swerve
