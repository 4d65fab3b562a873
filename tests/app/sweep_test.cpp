// The wear-versus-tracking sweep: one baseline run, then the wear-aware controller at each point,
// reported in order with the weight the cost actually used; bad points refused before any run.
#include "swerve/app/sweep.hpp"
#include "support/test_data.hpp"
#include "swerve/core/config_error.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace swerve {
namespace {

ScenarioConfig short_scenario() {
  ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  scenario.duration = 0.5;
  return scenario;
}

SweepPoint lambda(double value) { return {value, std::nullopt}; }

TEST(Sweep, RunsTheBaselineOnceThenEveryPointInOrder) {
  std::vector<std::string> calls;
  const SweepCallback record = [&calls](const SweepPoint* point, const ControllerRun& run) {
    calls.push_back(point == nullptr ? "baseline:" + run.name : "point:" + run.name);
  };
  const SweepResult result = run_sweep(short_scenario(), {}, {lambda(0.1), lambda(3.0)}, record);
  EXPECT_EQ(calls, (std::vector<std::string>{"baseline:kinematic_baseline", "point:wear_mpc", "point:wear_mpc"}));
  EXPECT_EQ(result.baseline.name, "kinematic_baseline");
  ASSERT_EQ(result.points.size(), 2u);
  EXPECT_DOUBLE_EQ(result.points[0].run.wear_weight, 0.1);
  EXPECT_DOUBLE_EQ(result.points[1].run.wear_weight, 3.0);
  for (const SweepRun& point : result.points) {
    EXPECT_TRUE(point.run.completed);
    EXPECT_EQ(point.run.metrics.steps, result.baseline.metrics.steps);
  }
}

TEST(Sweep, BaselineRunIsTheSameRunAsOnItsOwn) {
  const ScenarioConfig scenario = short_scenario();
  const SweepResult result = run_sweep(scenario, {}, {lambda(1.0)});
  const ScenarioController* baseline = nullptr;
  for (const ScenarioController& c : scenario.controllers) {
    if (c.name == "kinematic_baseline") baseline = &c;
  }
  ASSERT_NE(baseline, nullptr);
  // The baseline is deterministic for a seed, so the sweep's run must be it, bit for bit.
  const ControllerRun alone = run_controller(scenario, *baseline);
  EXPECT_EQ(result.baseline.metrics.wear_total, alone.metrics.wear_total);
  EXPECT_EQ(result.baseline.metrics.tracking_rmse_m, alone.metrics.tracking_rmse_m);
}

// A scenario that lists practical_baseline gets it run once too (after the points), the same run
// as on its own; one without it gets none.
TEST(Sweep, RunsThePracticalBaselineOnceWhenTheScenarioListsIt) {
  ScenarioConfig scenario = short_scenario();
  EXPECT_FALSE(run_sweep(scenario, {}, {lambda(1.0)}).practical.has_value());
  ScenarioController practical;
  for (const ScenarioController& c : scenario.controllers) {
    if (c.name == "kinematic_baseline") practical = c;
  }
  ASSERT_EQ(practical.name, "kinematic_baseline");
  practical.name = "practical_baseline";
  practical.config.baseline.cosine_scaling = true;
  practical.config.baseline.common_scaling = true;
  practical.config.baseline.pre_align = true;
  scenario.controllers.push_back(practical);
  const SweepResult result = run_sweep(scenario, {}, {lambda(1.0)});
  ASSERT_TRUE(result.practical.has_value());
  EXPECT_EQ(result.practical->name, "practical_baseline");
  const ControllerRun alone = run_controller(scenario, scenario.controllers.back());
  EXPECT_EQ(result.practical->metrics.wear_total, alone.metrics.wear_total);
  EXPECT_EQ(result.baseline.name, "kinematic_baseline");
}

TEST(Sweep, ReportsTheWearWeightAfterReferenceMassScaling) {
  // A controller giving its wear weight for an 800 kg vehicle (wear_reference_mass) scales it by
  // the mass ratio to the power wear_mass_exponent: at 1.75, on a vehicle of half that mass the
  // cost uses 2^1.75 times the weight.
  ScenarioConfig scenario = short_scenario();
  scenario.vehicle.mass = 400.0;
  for (ScenarioController& c : scenario.controllers) {
    c.config.mpc.wear_reference_mass = 800.0;
    c.config.mpc.wear_mass_exponent = 1.75;
  }
  const SweepResult result = run_sweep(scenario, {}, {lambda(0.25)});
  EXPECT_DOUBLE_EQ(result.points[0].run.wear_weight, 0.25);
  EXPECT_NEAR(result.points[0].run.effective_wear_weight, 0.25 * std::pow(2.0, 1.75), 1e-12);
  EXPECT_EQ(result.baseline.effective_wear_weight, 0.0);
}

TEST(Sweep, ToleranceSweepRunsTheTubeMode) {
  TrackingTolerance tube;
  tube.position = 0.05;
  tube.heading = 0.02;
  const SweepResult result = run_sweep(short_scenario(), {}, {{std::nullopt, tube}});
  ASSERT_EQ(result.points.size(), 1u);
  EXPECT_TRUE(result.points[0].run.completed);
  ASSERT_TRUE(result.points[0].point.tolerance.has_value());
  EXPECT_DOUBLE_EQ(result.points[0].point.tolerance->position, 0.05);
}

void expect_refused(const std::vector<SweepPoint>& points, const std::string& message_part) {
  int runs = 0;
  const SweepCallback count = [&runs](const SweepPoint*, const ControllerRun&) { ++runs; };
  try {
    run_sweep(short_scenario(), {}, points, count);
    FAIL() << "expected a ConfigError containing: " << message_part;
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find(message_part), std::string::npos) << error.what();
  }
  EXPECT_EQ(runs, 0) << "a bad point must be refused before any simulation";
}

TEST(Sweep, RefusesBadPointsBeforeRunningAnything) {
  expect_refused({}, "sweep: no points");
  expect_refused({lambda(1.0), lambda(-1.0)}, "sweep point[1].wear_weight = -1: must be finite and >= 0");
  expect_refused({lambda(std::nan(""))}, "sweep point[0].wear_weight = nan");
  TrackingTolerance both;
  both.position = 0.05;
  expect_refused({{1.0, both}}, "sweep point[0]: give exactly one of a wear weight and a tracking tolerance");
  expect_refused({{std::nullopt, std::nullopt}}, "give exactly one");
  expect_refused({{std::nullopt, TrackingTolerance{}}}, "sweep point[0].tolerance.position = 0");
}

TEST(Sweep, AScenarioWithoutTheWearAwareControllerIsAnOverrideError) {
  ScenarioConfig scenario = short_scenario();
  std::vector<ScenarioController> baseline_only;
  for (const ScenarioController& c : scenario.controllers) {
    if (c.name == "kinematic_baseline") baseline_only.push_back(c);
  }
  scenario.controllers = baseline_only;
  EXPECT_THROW(run_sweep(scenario, {}, {lambda(1.0)}), OverrideError);
}

// Shards of two different sweeps (another wear weight at point 1) share a scenario name and a
// point count; merge refuses them, naming the folder, rather than joining runs of neither.
TEST(SweepShards, MergeRefusesShardsOfAnotherSweepNamingTheFolder) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  const std::string dir = ::testing::TempDir() + "sweep_shards_" + std::to_string(::getpid());
  const auto write = [&](const std::string& name, int index, double second_weight) {
    SweepResult result{scenario, {}, {}, std::nullopt};
    result.baseline.name = "kinematic_baseline";
    std::filesystem::create_directories(dir + "/" + name);
    const std::vector<SweepPoint> points = {{0.1, std::nullopt}, {second_weight, std::nullopt}};
    result.points.push_back({points[static_cast<std::size_t>(index)], ControllerRun{}, index});
    write_sweep_shard({scenario.name, points, "seed 7", WorkClockRates{}}, result, Shard{index, 2},
                      dir + "/" + name + "/" + kShardFileName);
    return dir + "/" + name;
  };
  const std::string a = write("a", 0, 1.0), b = write("b", 1, 1.0), c = write("c", 1, 2.0);
  EXPECT_EQ(merge_sweep_shards({a, b}, dir + "/out").points.size(), 2u);
  try {
    merge_sweep_shards({a, c}, dir + "/out");
    FAIL() << "merged shards of two sweeps";
  } catch (const ConfigError& error) {
    EXPECT_EQ(std::string(error.what()).rfind("merge: " + c + " is a shard of another sweep run than " + a, 0), 0u)
        << error.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace swerve
