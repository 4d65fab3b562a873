// Horizon sizing for a target: rows per horizon, the recommendation rule, and bad input.
#include "swerve/app/tuning.hpp"

#include <gtest/gtest.h>

#include "support/fake_clocks.hpp"
#include "swerve/app/vehicle_config.hpp"

namespace swerve {
namespace {

std::string config_file(const std::string& name) { return std::string(SWERVE_SOURCE_DIR) + "/configs/" + name; }

struct Fixture {
  VehicleParams vehicle = load_vehicle_config_file(config_file("vehicles/agv_4wheel.yaml"));
  ControllerConfig controller = load_controller_config_file(config_file("controllers/default.yaml"));
  TargetConfig target;
  Fixture() {
    target.name = "test";
    target.control_period = 0.05;
    target.solve_budget = 0.004;
    target.cpu_slowdown = 2.0;
  }
};

// 10 us per clock read: SA reads it once per proposal, so a 2 ms budget holds the same number of
// proposals at every horizon, on any machine and under any load. (How the proposal count falls
// with the horizon on real hardware is a benchmark's question, not a test's.)
TuningOptions on_work_clock(const testing::WorkClock& clock) {
  TuningOptions options;
  options.clock = &clock;
  return options;
}

TEST(TuneHorizon, MeasuresEveryHorizonAtTheTargetsBudgetTranslatedToThisMachine) {
  Fixture f;
  const testing::WorkClock clock(10e-6);
  TuningOptions options = on_work_clock(clock);
  options.horizons = {5, 10};
  options.cycles = 3;
  options.min_proposals = 1;
  const TuningResult result = tune_horizon(f.vehicle, f.controller, f.target, options);
  ASSERT_EQ(result.rows.size(), 2u);
  for (const HorizonMeasurement& row : result.rows) {
    SCOPED_TRACE(row.horizon);
    EXPECT_DOUBLE_EQ(row.lookahead_s, row.horizon * 0.05);
    EXPECT_DOUBLE_EQ(row.budget_here_ms, 2.0);  // 4 ms on a target twice as slow
    // 2 ms at 10 us a read, less the reads outside the annealing loop and its kept-back slack.
    EXPECT_GT(row.proposals_median, 100.0);
    EXPECT_LT(row.proposals_median, 200.0);
    EXPECT_DOUBLE_EQ(row.target_p99_ms, f.target.cpu_slowdown * row.solve_p99_ms);
    EXPECT_EQ(row.fallbacks, 0);
    EXPECT_TRUE(row.qualifies);
  }
  // Both qualify: the rule recommends the largest.
  EXPECT_EQ(result.recommended_horizon, 10);
}

TEST(TuneHorizon, RecommendsNothingWhenNoHorizonGetsEnoughProposals) {
  Fixture f;
  const testing::WorkClock clock(10e-6);
  TuningOptions options = on_work_clock(clock);
  options.horizons = {5};
  options.cycles = 2;
  options.min_proposals = 1000000000;
  const TuningResult result = tune_horizon(f.vehicle, f.controller, f.target, options);
  EXPECT_FALSE(result.rows.at(0).qualifies);
  EXPECT_EQ(result.recommended_horizon, 0);
}

TEST(TuneHorizon, RejectsTheBaselineAndBadOptionsNamingTheField) {
  Fixture f;
  const ControllerConfig baseline = load_controller_config_file(config_file("controllers/kinematic_baseline.yaml"));
  try {
    tune_horizon(f.vehicle, baseline, f.target, TuningOptions{});
    FAIL() << "tuned a kinematic baseline";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("wear_mpc"), std::string::npos) << error.what();
  }
  TuningOptions bad;
  bad.horizons = {10, 0};
  try {
    tune_horizon(f.vehicle, f.controller, f.target, bad);
    FAIL() << "accepted horizon 0";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("horizons[] = 0"), std::string::npos) << error.what();
  }
  bad = TuningOptions{};
  bad.cycles = 0;
  EXPECT_THROW(tune_horizon(f.vehicle, f.controller, f.target, bad), ConfigError);
  TargetConfig slow = f.target;
  slow.solve_budget = 1.0;  // more than the control period
  EXPECT_THROW(tune_horizon(f.vehicle, f.controller, slow, TuningOptions{}), ConfigError);
}

}  // namespace
}  // namespace swerve
