// An embedded target: the computer the controller will run on, described by its control period,
// the share of it the solver may spend, and how much slower than this build machine it is. The
// `tune` step uses it to translate solve times measured here into the target's real-time budget.
#pragma once

#include <string>

#include "swerve/core/option_fields.hpp"
#include "swerve/app/config_node.hpp"

namespace swerve {

struct TargetConfig {
  std::string name;
  std::string description;
  double control_period = 0.05;     // s, the controller's cycle
  double solve_budget = 0.02;       // s, wall-clock time one solve may take on the target
  int cores = 1;                    // cores the controller may use
  double cpu_slowdown = 1.0;        // target time / build-machine time for the same solve (>= 1 slower)

  static const OptionFields<TargetConfig>& fields();  // the rules, read by the loader too
  // Throws ConfigError naming the field and value when a rule is broken.
  void validate() const;
};

// Reads the `target:` map of a config document (keys must all be known; see configs/targets/).
TargetConfig load_target_config(const config::ConfigNode& target_node);
// Loads a whole file with a top-level `target:` section and rejects unknown keys.
TargetConfig load_target_config_file(const std::string& file_path);

}  // namespace swerve
