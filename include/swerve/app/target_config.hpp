// An embedded target: the computer the controller will run on, described by its control period,
// the share of it the solver may spend, and how much slower than this build machine it is. The
// `tune` step uses it to translate solve times measured here into the target's real-time budget.
// A target may allow the controller other loop rates (other_periods), each with its own budget.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/app/config_node.hpp"

namespace swerve {

// A control period the target may run the controller at instead of its own, and the solve budget
// that period leaves (what else shares the core does not shrink with the period, so it is given,
// not scaled).
struct TargetPeriod {
  double control_period = 0.02;  // s
  double solve_budget = 0.008;   // s, <= control_period
};

struct TargetConfig {
  std::string name;
  std::string description;
  double control_period = 0.05;     // s, the controller's cycle
  double solve_budget = 0.02;       // s, wall-clock time one solve may take on the target
  int cores = 1;                    // cores the controller may use
  double cpu_slowdown = 1.0;        // target time / build-machine time for the same solve (>= 1 slower)
  // Loop rates the vehicle may also run the controller at (`swerve-mpc tune --periods` searches
  // them); empty: control_period only.
  std::vector<TargetPeriod> other_periods;

  // control_period first, then other_periods in order.
  std::vector<double> periods() const;
  // The solve budget at `period` (control_period or one of other_periods, to a nanosecond);
  // nullopt for a period the target does not allow.
  std::optional<double> budget_at(double period) const;
  // "0.05, 0.02": the periods allowed, for messages.
  std::string periods_text() const;

  static const OptionFields<TargetConfig>& fields();  // the rules, read by the loader too
  // Throws ConfigError naming the field and value when a rule is broken.
  void validate() const;
};

// Reads the `target:` map of a config document (keys must all be known; see configs/targets/).
TargetConfig load_target_config(const config::ConfigNode& target_node);
// Loads a whole file with a top-level `target:` section and rejects unknown keys.
TargetConfig load_target_config_file(const std::string& file_path);

}  // namespace swerve
