// TargetConfig: loading, defaults and every validation rule.
#include "swerve/app/target_config.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace swerve {
namespace {

TargetConfig load(const std::string& yaml) {
  const auto root = config::ConfigNode::parse(yaml, "target.yaml");
  TargetConfig target = load_target_config(root.child("target"));
  root.expect_all_read();
  return target;
}

TEST(TargetConfig, LoadsAllFieldsAndDefaults) {
  const TargetConfig target = load("target: {name: pi4, control_period: 0.05, solve_budget: 0.02}\n");
  EXPECT_EQ(target.name, "pi4");
  EXPECT_DOUBLE_EQ(target.control_period, 0.05);
  EXPECT_DOUBLE_EQ(target.solve_budget, 0.02);
  EXPECT_EQ(target.cores, 1);
  EXPECT_DOUBLE_EQ(target.cpu_slowdown, 1.0);
}

TEST(TargetConfig, BudgetLongerThanPeriodIsRejected) {
  try {
    load("target: {name: x, control_period: 0.01, solve_budget: 0.02}\n");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("target.solve_budget = 0.02"), std::string::npos) << error.what();
  }
}

TEST(TargetConfig, EachFieldIsValidated) {
  EXPECT_THROW(load("target: {name: x, control_period: 0, solve_budget: 0.01}\n"), ConfigError);
  EXPECT_THROW(load("target: {name: x, control_period: 0.05, solve_budget: -1}\n"), ConfigError);
  EXPECT_THROW(load("target: {name: x, control_period: 0.05, solve_budget: 0.01, cores: 0}\n"), ConfigError);
  EXPECT_THROW(load("target: {name: x, control_period: 0.05, solve_budget: 0.01, cpu_slowdown: 0}\n"),
               ConfigError);
  EXPECT_THROW(load("target: {control_period: 0.05, solve_budget: 0.01}\n"), ConfigError);
  EXPECT_THROW(load("target: {name: x, control_period: 0.05, solve_budget: 0.01, typo: 1}\n"), ConfigError);
}

TEST(TargetConfig, ValidateRejectsNonFiniteFieldsSetInCode) {
  TargetConfig target;
  target.control_period = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(target.validate(), ConfigError);
}

TEST(TargetConfig, ValidateAppliesEveryRuleToFieldsSetInCode) {
  // The YAML loader checks some rules itself; validate() must hold them for code-built targets too.
  TargetConfig target;
  target.solve_budget = target.control_period;  // equal is allowed: the solve fills the cycle
  EXPECT_NO_THROW(target.validate());
  auto expect_rejected = [](const TargetConfig& bad, const std::string& expected) {
    try {
      bad.validate();
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
  };
  TargetConfig late = target;
  late.solve_budget = 0.06;  // > control_period 0.05
  expect_rejected(late, "TargetConfig.solve_budget = 0.06");
  TargetConfig no_cores = target;
  no_cores.cores = 0;
  expect_rejected(no_cores, "TargetConfig.cores = 0");
}

// Issue 19's "control period where the target allows a choice".
TEST(TargetConfig, LoadsTheOtherPeriodsItAllowsEachWithItsBudget) {
  const TargetConfig target = load(
      "target:\n  name: ipc\n  control_period: 0.05\n  solve_budget: 0.02\n"
      "  other_periods:\n    - {control_period: 0.02, solve_budget: 0.008}\n"
      "    - {control_period: 0.025, solve_budget: 0.01}\n");
  ASSERT_EQ(target.other_periods.size(), 2u);
  EXPECT_EQ(target.periods(), (std::vector<double>{0.05, 0.02, 0.025}));
  EXPECT_DOUBLE_EQ(target.budget_at(0.05).value(), 0.02);
  EXPECT_DOUBLE_EQ(target.budget_at(0.02).value(), 0.008);
  EXPECT_DOUBLE_EQ(target.budget_at(0.025).value(), 0.01);
  EXPECT_DOUBLE_EQ(target.budget_at(0.02 + 1e-12).value(), 0.008);  // 0.02 typed and 0.02 computed
  EXPECT_FALSE(target.budget_at(0.03));
  EXPECT_EQ(target.periods_text(), "0.05, 0.02, 0.025");
  // None given: the control period alone.
  const TargetConfig single = load("target: {name: pi4, control_period: 0.05, solve_budget: 0.02}\n");
  EXPECT_EQ(single.periods(), std::vector<double>{0.05});
  EXPECT_FALSE(single.budget_at(0.02));
}

TEST(TargetConfig, AnOtherPeriodWithABudgetLongerThanItselfATwinOrAnUnknownKeyIsNamed) {
  const auto fails_with = [](const std::string& others, const std::string& expected) {
    try {
      load("target:\n  name: ipc\n  control_period: 0.05\n  solve_budget: 0.02\n  other_periods:\n" + others);
      ADD_FAILURE() << "accepted " << others;
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos) << error.what();
    }
  };
  fails_with("    - {control_period: 0.02, solve_budget: 0.03}\n", "other_periods[0].solve_budget = 0.03");
  fails_with("    - {control_period: 0.05, solve_budget: 0.01}\n", "other_periods[0].control_period = 0.05");
  fails_with("    - {control_period: 0.02, solve_budget: 0.01}\n    - {control_period: 0.02, solve_budget: 0.005}\n",
             "other_periods[1].control_period = 0.02");
  fails_with("    - {control_period: 0, solve_budget: 0.01}\n", "other_periods[0].control_period");
  fails_with("    - {control_period: 0.02}\n", "solve_budget");
  fails_with("    - {control_period: 0.02, solve_budget: 0.01, budget: 1}\n", "budget");
  fails_with("    0.02\n", "other_periods");
  // Set in code, validate() names the same fields.
  TargetConfig target;
  target.name = "ipc";
  target.other_periods = {{0.02, 0.03}};
  try {
    target.validate();
    ADD_FAILURE() << "accepted a budget longer than its period";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("other_periods[0].solve_budget = 0.03"), std::string::npos)
        << error.what();
  }
  target.other_periods = {{std::nan(""), 0.01}};
  EXPECT_THROW(target.validate(), ConfigError);
  target.other_periods = {{0.05, 0.01}};  // the control period itself
  EXPECT_THROW(target.validate(), ConfigError);
}

}  // namespace
}  // namespace swerve
