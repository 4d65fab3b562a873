#include "swerve/app/target_config.hpp"

#include <string>

#include "swerve/app/option_reader.hpp"

namespace swerve {

const OptionFields<TargetConfig>& TargetConfig::fields() {
  static const OptionFields<TargetConfig> table{
      {"control_period", &TargetConfig::control_period, Bound::positive()},
      {"solve_budget", &TargetConfig::solve_budget, Bound::positive()},
      {"cores", &TargetConfig::cores, Bound::closed(1, 1024)},
      {"cpu_slowdown", &TargetConfig::cpu_slowdown, Bound::positive()},
  };
  return table;
}

void TargetConfig::validate() const {
  check_fields("TargetConfig", *this, fields());
  if (solve_budget > control_period) {
    throw_invalid_field("TargetConfig", "solve_budget", solve_budget,
                        "must not exceed control_period (a solve must finish within its cycle)");
  }
}

TargetConfig load_target_config(const config::ConfigNode& node) {
  TargetConfig target;
  target.name = node.get_string("name");
  target.description = node.get_string_or("description", "");
  (void)node.child("control_period");  // required, as is solve_budget
  (void)node.child("solve_budget");
  config::read_fields(node, TargetConfig::fields(), &target);
  if (target.solve_budget > target.control_period) {
    node.fail_at("solve_budget", "= " + std::to_string(target.solve_budget) +
                                     ": must not exceed control_period (" +
                                     std::to_string(target.control_period) + ")");
  }
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
