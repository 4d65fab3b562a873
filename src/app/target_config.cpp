#include "swerve/app/target_config.hpp"

#include <cmath>
#include <sstream>
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

namespace {

// A period equal to another to a nanosecond is the same (0.02 typed and 0.02 read from a file).
bool same_period(double a, double b) { return std::abs(a - b) < 1e-9; }

}  // namespace

void TargetConfig::validate() const {
  check_fields("TargetConfig", *this, fields());
  if (solve_budget > control_period) {
    throw_invalid_field("TargetConfig", "solve_budget", solve_budget,
                        "must not exceed control_period (a solve must finish within its cycle)");
  }
  for (std::size_t i = 0; i < other_periods.size(); ++i) {
    const TargetPeriod& p = other_periods[i];
    const std::string field = "other_periods[" + std::to_string(i) + "]";
    if (!std::isfinite(p.control_period) || !(p.control_period > 0.0)) {
      throw_invalid_field("TargetConfig", field + ".control_period", p.control_period, "must be > 0 (s)");
    }
    if (!std::isfinite(p.solve_budget) || !(p.solve_budget > 0.0) || p.solve_budget > p.control_period) {
      throw_invalid_field("TargetConfig", field + ".solve_budget", p.solve_budget,
                          "must be > 0 and not exceed its control_period (" + Bound::number(p.control_period) + ")");
    }
    for (std::size_t j = 0; j <= i; ++j) {
      const double earlier = j == 0 ? control_period : other_periods[j - 1].control_period;
      if (same_period(p.control_period, earlier)) {
        throw_invalid_field("TargetConfig", field + ".control_period", p.control_period,
                            "is listed already: each period once");
      }
    }
  }
}

std::vector<double> TargetConfig::periods() const {
  std::vector<double> all{control_period};
  for (const TargetPeriod& p : other_periods) all.push_back(p.control_period);
  return all;
}

std::optional<double> TargetConfig::budget_at(double period) const {
  if (same_period(period, control_period)) return solve_budget;
  for (const TargetPeriod& p : other_periods) {
    if (same_period(period, p.control_period)) return p.solve_budget;
  }
  return std::nullopt;
}

std::string TargetConfig::periods_text() const {
  std::ostringstream text;
  const std::vector<double> all = periods();
  for (std::size_t i = 0; i < all.size(); ++i) text << (i == 0 ? "" : ", ") << all[i];
  return text.str();
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
  if (const auto others = node.optional_child("other_periods")) {
    if (!others->is_sequence()) others->fail("expected a list of {control_period, solve_budget}");
    for (std::size_t i = 0; i < others->size(); ++i) {
      const config::ConfigNode entry = others->at(i);
      TargetPeriod p;
      p.control_period = entry.get_double("control_period", Bound::positive());
      p.solve_budget = entry.get_double("solve_budget", Bound::positive());
      if (p.solve_budget > p.control_period) {
        entry.fail_at("solve_budget", "= " + Bound::number(p.solve_budget) + ": must not exceed control_period (" +
                                          Bound::number(p.control_period) + ")");
      }
      if (target.budget_at(p.control_period)) {
        entry.fail_at("control_period", "= " + Bound::number(p.control_period) + ": is listed already (" +
                                            target.periods_text() + "): each period once");
      }
      target.other_periods.push_back(p);
    }
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
