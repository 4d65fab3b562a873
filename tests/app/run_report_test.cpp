// The run report against hand-built metrics: the comparison numbers in summary.json and the
// terminal table are known answers (wear reductions, the RMSE ratio and their signs), not just
// "some number".
#include "swerve/app/run_report.hpp"
#include "support/test_data.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace swerve {
namespace {

ControllerRun hand_built_run(const std::string& name, ControllerKind kind, double wear_total, double rmse_m) {
  ControllerRun run;
  run.name = name;
  run.kind = kind;
  run.completed = true;
  run.metrics.steps = 10;
  run.metrics.wear_total = wear_total;
  run.metrics.wear_per_module = std::vector<double>(10, wear_total / 10.0);
  run.metrics.tracking_rmse_m = rmse_m;
  run.metrics.tracking_max_m = 2.0 * rmse_m;
  return run;
}

// wear_mpc 30, dynamic_no_wear 40, kinematic_baseline 60 (wear units); RMSE 0.06, 0.05, 0.04 m.
// By hand: vs the baseline 100 (60 - 30) / 60 = 50 % less wear, RMSE ratio 0.06 / 0.04 = 1.5;
// vs no-wear 100 (40 - 30) / 40 = 25 % less; no-wear vs the baseline 100 (60 - 40) / 60 = 33.33 %.
std::vector<ControllerRun> hand_built_runs() {
  return {hand_built_run("wear_mpc", ControllerKind::kWearMpc, 30.0, 0.06),
          hand_built_run("dynamic_no_wear", ControllerKind::kWearMpc, 40.0, 0.05),
          hand_built_run("kinematic_baseline", ControllerKind::kKinematicBaseline, 60.0, 0.04)};
}

// The inputs are exact in binary up to one rounding per operation: 1e-12 leaves room for that only.
constexpr double kArithmeticTolerance = 1e-12;

TEST(RunReport, WearReductionIsThePercentageOfTheReferenceWearSaved) {
  const std::vector<ControllerRun> runs = hand_built_runs();
  EXPECT_NEAR(wear_reduction_pct(runs[0].metrics, runs[2].metrics), 50.0, kArithmeticTolerance);
  EXPECT_NEAR(wear_reduction_pct(runs[0].metrics, runs[1].metrics), 25.0, kArithmeticTolerance);
  // More wear than the reference is a negative reduction.
  EXPECT_NEAR(wear_reduction_pct(runs[2].metrics, runs[0].metrics), -100.0, kArithmeticTolerance);
  RunMetrics no_wear;
  EXPECT_TRUE(std::isnan(wear_reduction_pct(runs[0].metrics, no_wear)));
}

TEST(RunReport, SummaryComparisonHasTheHandComputedValues) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  const nlohmann::json summary = nlohmann::json::parse(summary_json(scenario, hand_built_runs()));
  const nlohmann::json& comparison = summary.at("comparison");
  EXPECT_NEAR(comparison.at("wear_reduction_pct").get<double>(), 50.0, kArithmeticTolerance);
  EXPECT_NEAR(comparison.at("tracking_rmse_ratio").get<double>(), 1.5, kArithmeticTolerance);
  EXPECT_NEAR(comparison.at("wear_reduction_vs_no_wear_pct").get<double>(), 25.0, kArithmeticTolerance);
  EXPECT_EQ(comparison.at("paper_wear_reduction_pct").get<double>(), 65.2);
  EXPECT_EQ(summary.at("controllers").at("dynamic_no_wear").at("wear_total").get<double>(), 40.0);
}

TEST(RunReport, SummaryComparisonIsNullWhereItCannotBeComputed) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  std::vector<ControllerRun> runs = hand_built_runs();
  runs[2].metrics.wear_total = 0.0;       // a baseline without wear: no reduction to speak of
  runs[2].metrics.tracking_rmse_m = 0.0;  // nor a ratio
  const nlohmann::json comparison = nlohmann::json::parse(summary_json(scenario, runs)).at("comparison");
  EXPECT_TRUE(comparison.at("wear_reduction_pct").is_null());
  EXPECT_TRUE(comparison.at("tracking_rmse_ratio").is_null());
  EXPECT_NEAR(comparison.at("wear_reduction_vs_no_wear_pct").get<double>(), 25.0, kArithmeticTolerance);
  runs.pop_back();  // no baseline at all
  EXPECT_TRUE(nlohmann::json::parse(summary_json(scenario, runs))
                  .at("comparison")
                  .at("wear_reduction_pct")
                  .is_null());
}

TEST(RunReport, ComparisonTablePrintsTheWearChangeAsANegativePercentageWhenWearFalls) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  const std::string table = comparison_table(scenario, hand_built_runs());
  // Rows: the change against the baseline (wear falls: negative), "-" for the baseline itself.
  EXPECT_NE(table.find("wear_mpc                0.0600    0.1200"), std::string::npos) << table;
  EXPECT_NE(table.find("-50.00"), std::string::npos) << table;
  EXPECT_NE(table.find("-33.33"), std::string::npos) << table;
  EXPECT_EQ(table.find(" 50.00"), std::string::npos) << table;
  // Summary lines: the same signs, the RMSE ratio wear_mpc / baseline and the paper's figure.
  EXPECT_NE(
      table.find("wear_mpc vs kinematic_baseline: wear -50.00 %, tracking RMSE ratio 1.500  (paper: wear "
                 "-65.20 %)"),
      std::string::npos)
      << table;
  EXPECT_NE(table.find("wear_mpc vs dynamic_no_wear:    wear -25.00 %"), std::string::npos) << table;
}

}  // namespace
}  // namespace swerve
