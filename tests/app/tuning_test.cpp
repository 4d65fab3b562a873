// Tuning for a target. Sizing: rows per horizon, the recommendation rule, and bad input. Quality:
// the rounds, the selection rule, the bounds of an acceptable run, the written YAML, and bad input.
#include "swerve/app/tuning.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <tuple>

#include "support/fake_clocks.hpp"
#include "swerve/app/controller_config.hpp"
#include "swerve/app/scenario_runner.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/app/vehicle_config.hpp"

namespace swerve {
namespace {

std::string config_file(const std::string& name) { return std::string(SWERVE_SOURCE_DIR) + "/configs/" + name; }

// The shipped controller with its work budget off: these tests keep every budget on their own work
// clock (10 us a read), which their proposal counts and step times are worked out from.
ControllerConfig default_controller_on_the_tests_clock() {
  ControllerConfig controller = load_controller_config_file(config_file("controllers/default.yaml"));
  controller.mpc.work_budget.enabled = false;
  return controller;
}

struct Fixture {
  VehicleParams vehicle = load_vehicle_config_file(config_file("vehicles/agv_4wheel.yaml"));
  ControllerConfig controller = default_controller_on_the_tests_clock();
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

// --- Tuning by closed-loop quality ---

std::string test_data(const std::string& name) { return std::string(SWERVE_SOURCE_DIR) + "/tests/app/data/" + name; }

// Two short 60 deg offset runs (1.5 s, different noise seeds), with the wear-aware controller at a
// 2 ms budget here on a clock that advances 10 us per read: the same proposals on any machine.
struct QualityFixture {
  ControllerConfig controller = default_controller_on_the_tests_clock();
  TargetConfig target;
  std::vector<ScenarioConfig> scenarios;
  testing::WorkClock clock{10e-6};
  QualityTuningOptions options;
  QualityFixture() {
    target.name = "test";
    target.control_period = 0.05;
    target.solve_budget = 0.004;
    target.cpu_slowdown = 2.0;
    scenarios.push_back(load_scenario_config_file(test_data("short_offset60.yaml")));
    scenarios.push_back(scenarios.front());
    scenarios.back().name = "short_offset60_seed8";
    scenarios.back().simulator.seed = 8;
    options.horizons = {5, 10};
    options.knots = {3};
    options.clock = &clock;
  }
};

TEST(TuneByQuality, RunsEveryCandidateOnTheFirstScenarioThenTheBetterHalfAndTheIncumbentOnAll) {
  QualityFixture f;
  const QualityTuningResult result = tune_by_quality(f.controller, f.target, f.scenarios, f.options);
  EXPECT_DOUBLE_EQ(result.budget_here_s, 0.002);
  // (5, 3), (10, 3) and the controller file's own (20, 3), all at the file's own margin.
  ASSERT_EQ(result.candidates.size(), 3u);
  ASSERT_EQ(result.incumbent, 2);
  EXPECT_EQ(result.candidates[2].candidate.horizon, 20);
  EXPECT_EQ(result.candidates[2].candidate.knots, 3);
  for (const CandidateScore& c : result.candidates) EXPECT_DOUBLE_EQ(c.candidate.deadline_margin, f.controller.mpc.deadline_margin);
  int finalists = 0;
  for (const CandidateScore& c : result.candidates) {
    SCOPED_TRACE(c.candidate.horizon);
    ASSERT_FALSE(c.scenarios.empty());
    EXPECT_EQ(c.scenarios.front().scenario, "short_offset60");
    EXPECT_EQ(c.scenarios.size(), c.finalist ? 2u : 1u);
    finalists += c.finalist ? 1 : 0;
    // The geometric mean of what it ran, and the count of runs outside the bounds.
    double log_sum = 0.0;
    int unacceptable = 0;
    for (const ScenarioScore& s : c.scenarios) {
      EXPECT_TRUE(s.completed);
      EXPECT_GT(s.wear_ratio, 0.0);
      EXPECT_GT(s.baseline_rmse_m, 0.0);
      log_sum += std::log(s.wear_ratio);
      unacceptable += s.acceptable() ? 0 : 1;
    }
    EXPECT_NEAR(c.geomean_wear_ratio, std::exp(log_sum / static_cast<double>(c.scenarios.size())), 1e-12);
    EXPECT_EQ(c.unacceptable, unacceptable);
  }
  EXPECT_TRUE(result.candidates[2].finalist);  // the incumbent always is
  EXPECT_GE(finalists, 2);                     // the better half of three, and the incumbent
}

// The backend is a dimension of the search (issue 19): sa at every knot count, another backend once
// per horizon (its candidates carry 0 knots), each run with its own backend.
TEST(TuneByQuality, TriesSaAtEveryKnotCountAndAnotherBackendOncePerHorizon) {
  QualityFixture f;
  f.options.horizons = {5};
  f.options.knots = {2, 3};
  f.options.backends = {"sa", "nlopt"};
  const QualityTuningResult result = tune_by_quality(f.controller, f.target, f.scenarios, f.options);
  // (sa, 5, 2), (sa, 5, 3), (nlopt, 5), and the controller file's own (sa, 20, 3).
  ASSERT_EQ(result.candidates.size(), 4u);
  const TuningCandidate& nlopt = result.candidates[2].candidate;
  EXPECT_EQ(result.candidates[0].candidate.backend, "sa");
  EXPECT_EQ(result.candidates[0].candidate.knots, 2);
  EXPECT_EQ(result.candidates[1].candidate.knots, 3);
  EXPECT_EQ(nlopt.backend, "nlopt");
  EXPECT_EQ(nlopt.horizon, 5);
  EXPECT_EQ(nlopt.knots, 0);
  EXPECT_EQ(result.incumbent, 3);
  EXPECT_EQ(result.candidates[3].candidate.backend, f.controller.solver.backend);
  // On the work clock every run is repeatable: had the backend not been set, the nlopt candidate
  // would have run SA at the file's 3 knots and scored exactly as (sa, 5, 3).
  ASSERT_EQ(f.controller.solver.sa.knots, 3);
  ASSERT_FALSE(result.candidates[2].scenarios.empty());
  ASSERT_FALSE(result.candidates[1].scenarios.empty());
  EXPECT_NE(result.candidates[2].scenarios.front().wear_ratio, result.candidates[1].scenarios.front().wear_ratio);
  EXPECT_TRUE(result.candidates[2].scenarios.front().completed);
}

// The list the CLI counts before the search is the one the search runs: a setting equal to the
// controller's own is not run twice.
TEST(TuneByQuality, ListsTheControllersOwnSettingOnceWhenACandidateEqualsIt) {
  QualityFixture f;
  f.options.horizons = {5, 20};
  f.options.knots = {3};
  const QualityCandidates listed = quality_candidates(f.controller, f.options, f.target.control_period);
  ASSERT_EQ(listed.candidates.size(), 2u);  // (sa, 5, 3), (sa, 20, 3) = the file's own
  EXPECT_EQ(listed.incumbent, 1);
  EXPECT_EQ(listed.candidates[1].horizon, f.controller.mpc.horizon);
}

// Issue 19's dt axis: every dt at every horizon, the controller's own at the control period.
TEST(TuneByQuality, ListsEachPredictionStepAtEveryHorizonAndTheOwnSettingAtTheControlPeriod) {
  QualityFixture f;
  f.options.horizons = {5, 10};
  f.options.knots = {3};
  f.options.dts = {0.05, 0.1};
  const QualityCandidates listed = quality_candidates(f.controller, f.options, 0.05);
  ASSERT_EQ(listed.candidates.size(), 5u);  // (5, 10) x (0.05, 0.1), then the file's own (20, 0.05)
  EXPECT_DOUBLE_EQ(listed.candidates[0].dt, 0.05);
  EXPECT_DOUBLE_EQ(listed.candidates[2].dt, 0.1);
  EXPECT_EQ(listed.candidates[2].horizon, 5);
  EXPECT_EQ(listed.incumbent, 4);
  EXPECT_DOUBLE_EQ(listed.candidates[4].dt, 0.05);
  // Without dts: the control period alone, whatever the target's.
  f.options.dts.clear();
  for (const TuningCandidate& c : quality_candidates(f.controller, f.options, 0.04).candidates) {
    EXPECT_DOUBLE_EQ(c.dt, 0.04);
  }
}

TEST(TuneByQuality, RunsACandidateWithALongerStepAtTheTargetsPeriodAndRejectsAShorterStep) {
  QualityFixture f;
  f.options.horizons = {5};
  f.options.dts = {0.1};
  const QualityTuningResult result = tune_by_quality(f.controller, f.target, {f.scenarios.front()}, f.options);
  ASSERT_EQ(result.candidates.size(), 2u);  // (5, 0.1 s) and the file's own
  const ScenarioScore& longer = result.candidates[0].scenarios.front();
  EXPECT_TRUE(longer.completed);
  EXPECT_GT(longer.wear_ratio, 0.0);
  // A different controller from the own setting's at horizon 5 and 50 ms: it ran with the 0.1 s step.
  QualityTuningOptions at_period = f.options;
  at_period.dts = {0.05};
  const QualityTuningResult short_step = tune_by_quality(f.controller, f.target, {f.scenarios.front()}, at_period);
  EXPECT_NE(short_step.candidates[0].scenarios.front().rmse_m, longer.rmse_m);
  at_period.dts = {0.02};
  try {
    tune_by_quality(f.controller, f.target, f.scenarios, at_period);
    FAIL() << "accepted a step shorter than the control period";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("dts[] = 0.02"), std::string::npos) << error.what();
  }
}

// Issue 19's "control period where the target allows a choice": each period with each step at
// least as long, the target's own carried as 0, the file's own at the target's period.
TEST(TuneByQuality, ListsEachAllowedPeriodWithEveryStepAtLeastAsLongAndTheOwnSettingAtTheTargetsPeriod) {
  QualityFixture f;
  f.options.horizons = {5};
  f.options.knots = {3};
  f.options.periods = {0.05, 0.02};
  f.options.dts = {0.02, 0.05};
  const QualityCandidates listed = quality_candidates(f.controller, f.options, 0.05);
  ASSERT_EQ(listed.candidates.size(), 4u);  // 0.05: dt 0.05 (0.02 skipped); 0.02: dt 0.02 and 0.05; the own
  EXPECT_DOUBLE_EQ(listed.candidates[0].control_period, 0.0);
  EXPECT_DOUBLE_EQ(listed.candidates[0].dt, 0.05);
  EXPECT_DOUBLE_EQ(listed.candidates[1].control_period, 0.02);
  EXPECT_DOUBLE_EQ(listed.candidates[1].dt, 0.02);
  EXPECT_DOUBLE_EQ(listed.candidates[2].control_period, 0.02);
  EXPECT_DOUBLE_EQ(listed.candidates[2].dt, 0.05);
  EXPECT_DOUBLE_EQ(listed.candidates[2].period_at(0.05), 0.02);
  EXPECT_EQ(listed.incumbent, 3);
  EXPECT_DOUBLE_EQ(listed.candidates[3].control_period, 0.0);
  EXPECT_DOUBLE_EQ(listed.candidates[3].period_at(0.05), 0.05);
  EXPECT_EQ(listed.candidates[3].horizon, f.controller.mpc.horizon);
  // Without dts: each period's own step.
  f.options.dts.clear();
  const QualityCandidates own_steps = quality_candidates(f.controller, f.options, 0.05);
  ASSERT_EQ(own_steps.candidates.size(), 3u);
  EXPECT_DOUBLE_EQ(own_steps.candidates[1].step_at(0.05), 0.02);
}

// A candidate at another of the target's periods runs there at that period's budget; its wear is
// against the baseline at the target's period (one yardstick for all), its tracking against the
// better of the baseline there and at its own period.
TEST(TuneByQuality, RunsACandidateAtAnotherAllowedPeriodAtItsBudgetAgainstTheTighterBaseline) {
  QualityFixture f;
  f.target.other_periods = {{0.025, 0.002}};
  f.options.horizons = {5};
  f.options.periods = {0.025};
  f.options.dts = {0.05};
  const ScenarioConfig& scenario = f.scenarios.front();
  const QualityTuningResult result = tune_by_quality(f.controller, f.target, {scenario}, f.options);
  ASSERT_EQ(result.candidates.size(), 2u);  // (5, 0.05 s, every 25 ms) and the file's own
  ASSERT_DOUBLE_EQ(result.candidates[0].candidate.control_period, 0.025);
  const ScenarioScore& score = result.candidates[0].scenarios.front();
  // The same runs, by hand.
  const auto run_at = [&](const ScenarioController& entry, double period) {
    ScenarioConfig copy = scenario;
    copy.simulator.control_period = period;
    return run_controller(copy, entry, {}, 0, &f.clock).metrics;
  };
  ScenarioController baseline{"kinematic_baseline", "",
                              load_controller_config_file(config_file("controllers/kinematic_baseline.yaml"))};
  for (const ScenarioController& c : scenario.controllers) {
    if (c.config.kind == ControllerKind::kKinematicBaseline) baseline = c;
  }
  baseline.config.set_sampling(baseline.config.baseline.horizon, 0.05);
  const RunMetrics at_target = run_at(baseline, 0.05);
  baseline.config.set_sampling(baseline.config.baseline.horizon, 0.025);
  const RunMetrics at_own = run_at(baseline, 0.025);
  ScenarioController candidate{"wear_mpc", "", f.controller};
  candidate.config.set_sampling(5, 0.05);
  candidate.config.mpc.control_period = 0.025;
  candidate.config.mpc.solve_budget = 0.001;  // 2 ms on a target twice as slow
  const RunMetrics own = run_at(candidate, 0.025);
  EXPECT_NE(at_target.tracking_rmse_m, at_own.tracking_rmse_m);  // else the test shows nothing
  EXPECT_DOUBLE_EQ(score.rmse_m, own.tracking_rmse_m);
  EXPECT_DOUBLE_EQ(score.wear_ratio, own.wear_total / at_target.wear_total);
  EXPECT_DOUBLE_EQ(score.baseline_rmse_m, std::min(at_target.tracking_rmse_m, at_own.tracking_rmse_m));
  EXPECT_DOUBLE_EQ(score.baseline_heading_rmse_rad, std::min(at_target.heading_rmse_rad, at_own.heading_rmse_rad));
  EXPECT_DOUBLE_EQ(score.target_period_baseline_rmse_m, at_target.tracking_rmse_m);  // the tables' yardstick
  const ScenarioScore& own_setting = result.candidates[1].scenarios.front();
  EXPECT_DOUBLE_EQ(own_setting.target_period_baseline_rmse_m, own_setting.baseline_rmse_m);
  // A period the target does not allow, and a step shorter than every period tried, are named.
  f.options.periods = {0.03};
  try {
    tune_by_quality(f.controller, f.target, {scenario}, f.options);
    FAIL() << "accepted a period the target does not allow";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("periods[] = 0.03"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("0.05, 0.025"), std::string::npos) << error.what();
  }
  f.options.periods = {0.025};
  f.options.dts = {0.02};
  try {
    tune_by_quality(f.controller, f.target, {scenario}, f.options);
    FAIL() << "accepted a step shorter than every period tried";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("dts[] = 0.02"), std::string::npos) << error.what();
  }
}

TEST(TuneByQuality, ChoosesTheLeastWearAmongFinalistsAcceptableOnEveryScenario) {
  QualityFixture f;
  const QualityTuningResult result = tune_by_quality(f.controller, f.target, f.scenarios, f.options);
  for (std::size_t i = 0; i < result.candidates.size(); ++i) {
    const CandidateScore& c = result.candidates[i];
    if (!c.finalist || c.unacceptable > 0) continue;
    ASSERT_GE(result.best, 0) << "an acceptable finalist was not chosen";
    EXPECT_LE(result.candidates[static_cast<std::size_t>(result.best)].geomean_wear_ratio, c.geomean_wear_ratio);
  }
  if (result.best >= 0) {
    const CandidateScore& best = result.candidates[static_cast<std::size_t>(result.best)];
    EXPECT_TRUE(best.finalist);
    EXPECT_EQ(best.unacceptable, 0);
  }
}

// Scores on two scenarios, as a finalist: wear ratio and position RMSE per scenario (the baseline
// 0.1 m, so every RMSE below 0.12 m is within the bounds).
CandidateScore scored(double wear_a, double rmse_a, double wear_b, double rmse_b) {
  CandidateScore c;
  for (const auto& [name, wear, rmse] : {std::tuple{"a", wear_a, rmse_a}, std::tuple{"b", wear_b, rmse_b}}) {
    ScenarioScore s;
    s.scenario = name;
    s.completed = true;
    s.wear_ratio = wear;
    s.rmse_m = rmse;
    s.baseline_rmse_m = 0.1;
    c.scenarios.push_back(s);
  }
  c.geomean_wear_ratio = std::sqrt(wear_a * wear_b);
  c.finalist = true;
  return c;
}

// Issue 19: a tuned file no worse than the hand-set one on every scenario, where one exists; else
// the least wear within the bounds.
TEST(TuneByQuality, PrefersACandidateNoWorseThanTheFilesOwnOnEveryScenarioThenTheLeastWear) {
  const CandidateScore own = scored(0.5, 0.10, 0.5, 0.10);
  const CandidateScore less_wear_worse_tracking = scored(0.3, 0.11, 0.3, 0.09);  // geo 0.30
  const CandidateScore no_worse = scored(0.45, 0.10, 0.4, 0.08);                // geo 0.42
  const CandidateScore no_worse_more_wear = scored(0.5, 0.09, 0.5, 0.09);       // geo 0.50
  EXPECT_TRUE(no_worse_on_every_scenario(no_worse, own));
  EXPECT_TRUE(no_worse_on_every_scenario(own, own));
  EXPECT_FALSE(no_worse_on_every_scenario(less_wear_worse_tracking, own));
  EXPECT_FALSE(no_worse_on_every_scenario(scored(0.51, 0.05, 0.1, 0.05), own));  // more wear on one
  // Not the same scenarios: no comparison.
  CandidateScore other_scenarios = no_worse;
  other_scenarios.scenarios.back().scenario = "c";
  EXPECT_FALSE(no_worse_on_every_scenario(other_scenarios, own));
  other_scenarios.scenarios.pop_back();
  EXPECT_FALSE(no_worse_on_every_scenario(other_scenarios, own));

  // The no-worse one with the least wear, ahead of one with less wear that tracks worse somewhere.
  EXPECT_EQ(best_candidate({own, less_wear_worse_tracking, no_worse_more_wear, no_worse}, 0), 3);
  // None no worse: the least wear, the file's own included.
  EXPECT_EQ(best_candidate({own, less_wear_worse_tracking}, 0), 1);
  EXPECT_EQ(best_candidate({scored(0.2, 0.11, 0.2, 0.11), own}, 1), 0);
  // Only finalists acceptable on every scenario count, however little they wear.
  CandidateScore outside = scored(0.1, 0.2, 0.1, 0.05);  // 0.2 m against a 0.12 m bound
  outside.unacceptable = 1;
  CandidateScore round_one = no_worse;
  round_one.finalist = false;
  EXPECT_EQ(best_candidate({own, outside, round_one}, 0), 0);
  EXPECT_EQ(best_candidate({outside}, -1), -1);
}

// Round 1 halves by the same order on the first scenario: one no worse than the file's own there
// goes on ahead of one that wears less and tracks worse, so the rule's preference is not cut early.
TEST(TuneByQuality, RanksByTheBoundsThenNoWorseThanTheFilesOwnThenTheLeastWear) {
  const auto on_first = [](double wear, double rmse, int unacceptable = 0) {
    CandidateScore c = scored(wear, rmse, wear, rmse);
    c.scenarios.pop_back();
    c.geomean_wear_ratio = wear;
    c.unacceptable = unacceptable;
    c.finalist = false;
    return c;
  };
  const std::vector<CandidateScore> round_one{
      on_first(0.5, 0.10),          // 0: the file's own
      on_first(0.3, 0.11),          // 1: less wear, worse tracking
      on_first(0.45, 0.09),         // 2: no worse than the own
      on_first(0.2, 0.2, 1),        // 3: outside the bounds
      on_first(0.48, 0.10),         // 4: no worse, more wear than 2
  };
  EXPECT_EQ(rank_candidates(round_one, 0), (std::vector<int>{2, 4, 1, 0, 3}));
  // Without an incumbent: the bounds, then the wear.
  EXPECT_EQ(rank_candidates(round_one, -1), (std::vector<int>{1, 2, 4, 0, 3}));
}

// With seeds, a candidate's score on a scenario is the median over them (two seeds: the mean) and
// its misses the sum; each seed alone gives that seed's run (the work clock makes runs repeatable).
TEST(TuneByQuality, ScoresEachScenarioByTheMedianOverTheSeeds) {
  QualityFixture f;
  f.scenarios.pop_back();  // the first scenario only
  f.options.horizons = {5};
  const auto score_with = [&](std::vector<std::uint64_t> seeds) {
    QualityTuningOptions options = f.options;
    options.seeds = std::move(seeds);
    const QualityTuningResult result = tune_by_quality(f.controller, f.target, f.scenarios, options);
    return result.candidates.at(0).scenarios.at(0);  // (5, 3)
  };
  const ScenarioScore both = score_with({7, 8});
  const ScenarioScore seven = score_with({7});
  const ScenarioScore eight = score_with({8});
  EXPECT_NE(seven.rmse_m, eight.rmse_m);  // the seeds do change the run
  EXPECT_NEAR(both.wear_ratio, 0.5 * (seven.wear_ratio + eight.wear_ratio), 1e-12);
  EXPECT_NEAR(both.rmse_m, 0.5 * (seven.rmse_m + eight.rmse_m), 1e-12);
  EXPECT_NEAR(both.baseline_rmse_m, 0.5 * (seven.baseline_rmse_m + eight.baseline_rmse_m), 1e-12);
  EXPECT_NEAR(both.heading_rmse_rad, 0.5 * (seven.heading_rmse_rad + eight.heading_rmse_rad), 1e-12);
  EXPECT_EQ(both.deadline_misses, seven.deadline_misses + eight.deadline_misses);
  EXPECT_DOUBLE_EQ(both.step_p99_ms, std::max(seven.step_p99_ms, eight.step_p99_ms));
}

// A work clock (10 us a read) that, once armed, jumps by `stall_s` at its `after`-th read from then:
// once (one scheduling stall of the operating system), or every `after` reads from then on.
class StallingClock final : public Clock {
 public:
  StallingClock(double stall_s, long after, bool once) : stall_(to_duration(stall_s)), after_(after), once_(once) {}
  TimePoint now() const noexcept override {
    now_ += to_duration(10e-6);
    if (armed_ && --countdown_ == 0) {
      now_ += stall_;
      armed_ = !once_;
      countdown_ = after_;
      ++stalls_;
    }
    return now_;
  }
  void arm() noexcept {
    armed_ = true;
    countdown_ = after_;
  }
  int stalls() const noexcept { return stalls_; }

 private:
  Duration stall_;
  long after_;
  bool once_;
  mutable TimePoint now_{};
  mutable bool armed_ = false;
  mutable long countdown_ = 0;
  mutable int stalls_ = 0;
};

// A run that missed is run again, and only misses that recur count: one 30 ms stall inside the
// second candidate's run (a miss at a 2 ms budget) does not make it unacceptable.
TEST(TuneByQuality, AMissThatDoesNotRecurWhenItsRunIsRepeatedIsTheMachinesAndDoesNotCount) {
  QualityFixture f;
  StallingClock clock(0.03, 50, /*once=*/true);
  f.options.clock = &clock;
  f.options.horizons = {5};  // with the controller file's own: two candidates
  f.scenarios.pop_back();
  const QualityTuningResult result =
      tune_by_quality(f.controller, f.target, f.scenarios, f.options, [&](int done, int, int round) {
        if (round == 1 && done == 1) clock.arm();  // the stall lands in the next candidate's run
      });
  ASSERT_EQ(clock.stalls(), 1);
  ASSERT_EQ(result.candidates.size(), 2u);
  const ScenarioScore& calm = result.candidates[0].scenarios.front();
  const ScenarioScore& stalled = result.candidates[1].scenarios.front();
  EXPECT_EQ(calm.deadline_misses, 0);
  EXPECT_EQ(calm.unconfirmed_misses, 0);
  EXPECT_GE(stalled.unconfirmed_misses, 1);
  EXPECT_EQ(stalled.deadline_misses, 0);
}

// A candidate whose runs miss every time (here: a 30 ms stall every 500 clock reads, in the run
// and in its repeat; the shipped controller pre-aligns this start, so its runs solve less often)
// keeps its misses and is not acceptable.
TEST(TuneByQuality, AMissThatRecursWhenItsRunIsRepeatedCounts) {
  QualityFixture f;
  StallingClock clock(0.03, 500, /*once=*/false);
  f.options.clock = &clock;
  f.options.horizons = {5};
  f.scenarios.pop_back();
  const QualityTuningResult result =
      tune_by_quality(f.controller, f.target, f.scenarios, f.options, [&](int done, int, int round) {
        if (round == 1 && done == 1) clock.arm();  // from the second candidate's run on, for good
      });
  ASSERT_EQ(result.candidates.size(), 2u);
  const ScenarioScore& stalled = result.candidates[1].scenarios.front();
  EXPECT_GE(stalled.deadline_misses, 1);
  EXPECT_FALSE(stalled.acceptable());
}

// The real-time report counts misses as the tuner does: one stall inside a run (a miss at a 2 ms
// budget) that its repeat does not have is the machine's; a stall in every run is the controller's.
TEST(MeasureRealTime, CountsOnlyTheMissesThatRecurWhenTheRunIsRepeated) {
  QualityFixture f;
  StallingClock once(0.03, 50, /*once=*/true);
  once.arm();
  const std::vector<RealTimeRow> stalled_once = measure_real_time(f.controller, f.target, {f.scenarios.front()}, &once);
  ASSERT_EQ(once.stalls(), 1);
  EXPECT_EQ(stalled_once.front().deadline_misses, 0);
  EXPECT_GE(stalled_once.front().unconfirmed_misses, 1);
  EXPECT_GT(stalled_once.front().step_max_ms, 4.0);  // the first run's times are kept, the stall in them
  // Every 500 reads: the shipped controller pre-aligns this start on its 90 deg-steering vehicle,
  // and a run that solves less often must still see a stall in a solve.
  StallingClock always(0.03, 500, /*once=*/false);
  always.arm();
  const std::vector<RealTimeRow> stalled = measure_real_time(f.controller, f.target, {f.scenarios.front()}, &always);
  EXPECT_GE(stalled.front().deadline_misses, 1);
  EXPECT_FALSE(stalled.front().passes());
}

TEST(TuneByQuality, AcceptsARunWithinTheBaselinesTrackingBoundsAndWithoutMisses) {
  ScenarioScore s;
  s.completed = true;
  s.baseline_rmse_m = 0.5;
  s.rmse_m = 0.55;  // 1.1 x 0.5: the relative bound
  s.baseline_heading_rmse_rad = 0.1;
  s.heading_rmse_rad = 0.11;
  EXPECT_TRUE(s.acceptable());
  s.rmse_m = 0.5501;
  EXPECT_FALSE(s.acceptable());
  s.baseline_rmse_m = 0.01;  // small: the absolute bound, + 0.02 m
  s.rmse_m = 0.03;
  EXPECT_TRUE(s.acceptable());
  s.rmse_m = 0.0301;
  EXPECT_FALSE(s.acceptable());
  s.rmse_m = 0.01;
  s.baseline_heading_rmse_rad = 0.001;  // small: + 0.5 deg
  s.heading_rmse_rad = 0.001 + 0.5 * 3.14159265358979323846 / 180.0 - 1e-9;
  EXPECT_TRUE(s.acceptable());
  s.heading_rmse_rad += 2e-9;
  EXPECT_FALSE(s.acceptable());
  s.heading_rmse_rad = 0.001;
  s.deadline_misses = 1;
  EXPECT_FALSE(s.acceptable());
  s.deadline_misses = 0;
  s.completed = false;
  EXPECT_FALSE(s.acceptable());
}

TEST(TuneByQuality, MeasuresTheTrackingExcessAsTheWorseRatioToEitherBound) {
  ScenarioScore s;
  s.completed = true;
  s.baseline_rmse_m = 0.5;            // position bound 0.55 (1.1x)
  s.baseline_heading_rmse_rad = 0.1;  // heading bound 0.11 (1.1x)
  s.rmse_m = 0.66;
  s.heading_rmse_rad = 0.055;
  EXPECT_NEAR(s.tracking_excess(), 1.2, 1e-12);  // 0.66 / 0.55 against 0.055 / 0.11
  s.rmse_m = 0.275;
  s.heading_rmse_rad = 0.143;
  EXPECT_NEAR(s.tracking_excess(), 1.3, 1e-12);  // the heading's 0.143 / 0.11
  s.baseline_rmse_m = 0.01;                      // small: + 0.02 m, a 0.03 m bound
  s.rmse_m = 0.015;
  s.heading_rmse_rad = 0.0;
  EXPECT_NEAR(s.tracking_excess(), 0.5, 1e-12);
  EXPECT_TRUE(s.acceptable());
}

// Hand-built scores: a candidate that ran every scenario (2) without a deadline miss, by its worst
// scenario's excess, then by the least wear; one that missed a deadline or did not run everything
// never qualifies.
TEST(TuneByQuality, TheClosestCandidateIsTheOneWhoseWorstScenarioIsNearestTheBoundsWithoutAMiss) {
  const auto scenario = [](double rmse_ratio, int misses) {
    ScenarioScore s;
    s.completed = true;
    s.baseline_rmse_m = 1.0;  // bound 1.1 m
    s.rmse_m = 1.1 * rmse_ratio;
    s.baseline_heading_rmse_rad = 1.0;
    s.heading_rmse_rad = 0.0;
    s.deadline_misses = misses;
    return s;
  };
  const auto candidate = [](std::vector<ScenarioScore> scenarios, double geomean) {
    CandidateScore c;
    c.scenarios = std::move(scenarios);
    c.geomean_wear_ratio = geomean;
    c.finalist = c.scenarios.size() == 2;
    return c;
  };
  std::vector<CandidateScore> candidates{
      candidate({scenario(1.30, 0), scenario(1.00, 0)}, 0.30),  // worst 1.30
      candidate({scenario(1.10, 0), scenario(1.20, 1)}, 0.20),  // a miss
      candidate({scenario(1.05, 0)}, 0.10),                     // one scenario only
      candidate({scenario(1.20, 0), scenario(1.25, 0)}, 0.50),  // worst 1.25: the closest
      candidate({scenario(0.90, 0), scenario(1.25, 0)}, 0.40),  // worst 1.25 as well, less wear
  };
  EXPECT_EQ(closest_candidate(candidates, 2), 4);
  candidates[4].scenarios[0].completed = false;  // a run that stopped early
  EXPECT_EQ(closest_candidate(candidates, 2), 3);
  candidates[3].scenarios[1].deadline_misses = 2;
  candidates[0].scenarios[0].deadline_misses = 1;
  EXPECT_EQ(closest_candidate(candidates, 2), -1);
  EXPECT_EQ(closest_candidate({}, 2), -1);
}

TEST(TuneByQuality, WritesTheWinnersControllerWhichLoadsWithItsSettingsAndKeepsTheRest) {
  const std::string base = config_file("controllers/default.yaml");
  const std::string path = ::testing::TempDir() + "tuned_controller.yaml";
  TargetConfig target;
  target.name = "test";
  target.control_period = 0.02;
  target.solve_budget = 0.01;
  write_tuned_controller(base, TuningCandidate{30, 6, 0.3}, target, "# tuned for a test\n", path);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str().rfind("# tuned for a test\n", 0), 0u) << text.str();
  // Numbers as a user would write them (yaml-cpp wrote 0.3 as 0.29999999999999999).
  EXPECT_NE(text.str().find("deadline_margin: 0.3\n"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("dt: 0.02\n"), std::string::npos) << text.str();
  const ControllerConfig tuned = load_controller_config_file(path);
  const ControllerConfig original = load_controller_config_file(base);
  EXPECT_EQ(tuned.mpc.horizon, 30);
  EXPECT_EQ(tuned.baseline.horizon, 30);
  EXPECT_DOUBLE_EQ(tuned.mpc.dt, 0.02);
  EXPECT_DOUBLE_EQ(tuned.mpc.solve_budget, 0.01);
  EXPECT_EQ(tuned.solver.sa.knots, 6);
  EXPECT_DOUBLE_EQ(tuned.mpc.deadline_margin, 0.3);
  EXPECT_DOUBLE_EQ(tuned.mpc.wear_weight, original.mpc.wear_weight);
  EXPECT_EQ(tuned.mpc.pose_weight, original.mpc.pose_weight);
  EXPECT_DOUBLE_EQ(tuned.solver.sa.polish_share, original.solver.sa.polish_share);
  EXPECT_EQ(tuned.mpc.work_budget.enabled, original.mpc.work_budget.enabled);
  EXPECT_DOUBLE_EQ(tuned.mpc.work_budget.seconds_per_read, original.mpc.work_budget.seconds_per_read);
  std::remove(path.c_str());
}

TEST(TuneByQuality, WritesTheWorkBudgetsRatesScaledByTheTargetsSlowdown) {
  // The tuner ran the candidates here at the base file's rates on budget / cpu_slowdown; on the
  // target the same work takes cpu_slowdown times as long.
  // The shipped controller, whose work budget is on.
  const std::string base = config_file("controllers/default.yaml");
  const std::string path = ::testing::TempDir() + "tuned_slow_target.yaml";
  TargetConfig target;
  target.name = "test";
  target.control_period = 0.05;
  target.solve_budget = 0.02;
  target.cpu_slowdown = 4.0;
  write_tuned_controller(base, TuningCandidate{10, 3, 0.15}, target, "# tuned for a test\n", path);
  const WorkBudgetOptions tuned = load_controller_config_file(path).mpc.work_budget;
  const WorkBudgetOptions original = load_controller_config_file(base).mpc.work_budget;
  ASSERT_TRUE(original.enabled);
  EXPECT_TRUE(tuned.enabled);
  EXPECT_DOUBLE_EQ(tuned.seconds_per_read, 4.0 * original.seconds_per_read);
  EXPECT_DOUBLE_EQ(tuned.seconds_per_module_evaluation, 4.0 * original.seconds_per_module_evaluation);
  std::remove(path.c_str());
}

// Adds a failure for every key one YAML tree has and the other lacks, and every value that
// differs (numbers as numbers: 1.0e-9 is 1e-09), each named by its key path.
void expect_same_tree(const YAML::Node& expected, const YAML::Node& actual, const std::string& path) {
  if (expected.IsMap() && actual.IsMap()) {
    for (const auto& entry : expected) {
      const std::string key = entry.first.as<std::string>();
      if (!actual[key]) {
        ADD_FAILURE() << path << "." << key << " is missing";
        continue;
      }
      expect_same_tree(entry.second, actual[key], path + "." + key);
    }
    for (const auto& entry : actual) {
      const std::string key = entry.first.as<std::string>();
      if (!expected[key]) ADD_FAILURE() << path << "." << key << " is not in the file it was tuned from";
    }
    return;
  }
  if (expected.IsSequence() && actual.IsSequence() && expected.size() == actual.size()) {
    for (std::size_t i = 0; i < expected.size(); ++i) {
      expect_same_tree(expected[i], actual[i], path + "[" + std::to_string(i) + "]");
    }
    return;
  }
  if (expected.IsScalar() && actual.IsScalar()) {
    double a = 0.0, b = 0.0;
    if (YAML::convert<double>::decode(expected, a) && YAML::convert<double>::decode(actual, b)) {
      EXPECT_NEAR(b, a, 1e-12 * std::abs(a)) << path;
    } else {
      EXPECT_EQ(actual.as<std::string>(), expected.as<std::string>()) << path;
    }
    return;
  }
  ADD_FAILURE() << path << ": " << actual << " where the default has " << expected;
}

// Each shipped tuned file (configs/controllers/tuned/<target>.yaml) is what the tuner writes:
// configs/controllers/default.yaml with the file's own candidate written over it. Re-written here
// and compared setting by setting, so a setting the default gains later cannot go missing on the
// targets that use a tuned file. (Tuned before the default had them, the shipped files lacked the
// baseline's pre-alignment, the stuck-steering detector and the work budget.)
TEST(TunedControllerFiles, EachShippedTunedFileIsTheDefaultWithItsOwnCandidateWrittenOverIt) {
  for (const std::string name : {"default", "jetson_orin_nano", "raspberry_pi_4"}) {
    SCOPED_TRACE(name);
    const std::string shipped = config_file("controllers/tuned/" + name + ".yaml");
    const ControllerConfig tuned = load_controller_config_file(shipped);
    const TargetConfig target = load_target_config_file(config_file("targets/" + name + ".yaml"));
    TuningCandidate candidate;
    candidate.horizon = tuned.mpc.horizon;
    candidate.knots = tuned.solver.sa.knots;
    candidate.deadline_margin = tuned.mpc.deadline_margin;
    candidate.backend = tuned.solver.backend;
    candidate.dt = tuned.mpc.dt;
    candidate.control_period = tuned.mpc.period();
    const std::string rewritten = ::testing::TempDir() + "tuned_" + name + ".yaml";
    write_tuned_controller(config_file("controllers/default.yaml"), candidate, target, "", rewritten);
    expect_same_tree(YAML::LoadFile(rewritten), YAML::LoadFile(shipped), "");
    if (::testing::Test::HasFailure()) std::printf("%s: what the tuner writes: %s\n", name.c_str(), rewritten.c_str());
  }
}

TEST(TuneByQuality, WritesALongerStepWithTheTargetsControlPeriodAndDropsItAtThePeriod) {
  const std::string base = config_file("controllers/default.yaml");
  const std::string path = ::testing::TempDir() + "tuned_longer_step.yaml";
  TargetConfig target;
  target.name = "test";
  target.control_period = 0.05;
  target.solve_budget = 0.02;
  TuningCandidate candidate{10, 3, 0.15, "sa", 0.1};
  write_tuned_controller(base, candidate, target, "# tuned for a test\n", path);
  ControllerConfig tuned = load_controller_config_file(path);
  EXPECT_DOUBLE_EQ(tuned.mpc.dt, 0.1);
  EXPECT_DOUBLE_EQ(tuned.period(), 0.05);
  EXPECT_EQ(tuned.mpc.horizon, 10);
  // Tuned again from that file at the period: no control_period key is left behind.
  candidate.dt = 0.05;
  write_tuned_controller(path, candidate, target, "# tuned for a test\n", path);
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str().find("control_period"), std::string::npos) << text.str();
  tuned = load_controller_config_file(path);
  EXPECT_DOUBLE_EQ(tuned.mpc.dt, 0.05);
  EXPECT_DOUBLE_EQ(tuned.period(), 0.05);
  std::remove(path.c_str());
}

TEST(TuneByQuality, WritesACandidateAtAnotherAllowedPeriodWithThatPeriodAndItsBudget) {
  const std::string base = config_file("controllers/default.yaml");
  const std::string path = ::testing::TempDir() + "tuned_other_period.yaml";
  TargetConfig target;
  target.name = "test";
  target.control_period = 0.05;
  target.solve_budget = 0.02;
  target.other_periods = {{0.02, 0.008}};
  TuningCandidate candidate{10, 3, 0.3, "sa", 0.05, 0.02};
  write_tuned_controller(base, candidate, target, "# tuned for a test\n", path);
  const ControllerConfig tuned = load_controller_config_file(path);
  EXPECT_DOUBLE_EQ(tuned.mpc.dt, 0.05);
  EXPECT_DOUBLE_EQ(tuned.period(), 0.02);
  EXPECT_DOUBLE_EQ(tuned.mpc.solve_budget, 0.008);
  // A period the target does not allow has no budget to write.
  candidate.control_period = 0.025;
  try {
    write_tuned_controller(base, candidate, target, "# tuned for a test\n", path);
    FAIL() << "wrote a period the target does not allow";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("0.05, 0.02"), std::string::npos) << error.what();
  }
  std::remove(path.c_str());
}

TEST(TuneByQuality, WritesAnotherBackendsWinnerWithItsBackendAndLeavesTheSaKnotsAlone) {
  const std::string base = config_file("controllers/default.yaml");
  const std::string path = ::testing::TempDir() + "tuned_nlopt_controller.yaml";
  TargetConfig target;
  target.name = "test";
  target.control_period = 0.05;
  target.solve_budget = 0.02;
  write_tuned_controller(base, TuningCandidate{15, 0, 0.2, "nlopt"}, target, "# tuned for a test\n", path);
  const ControllerConfig tuned = load_controller_config_file(path);
  const ControllerConfig original = load_controller_config_file(base);
  EXPECT_EQ(tuned.solver.backend, "nlopt");
  EXPECT_EQ(tuned.mpc.horizon, 15);
  EXPECT_EQ(tuned.solver.sa.knots, original.solver.sa.knots);
  EXPECT_EQ(tuned.solver.nlopt.algorithm, original.solver.nlopt.algorithm);
  std::remove(path.c_str());
}

TEST(TuneByQuality, RejectsAScenarioWithoutABaselineAndBadOptionsNamingThem) {
  QualityFixture f;
  std::vector<ScenarioConfig> without = {f.scenarios.front()};
  without.front().controllers.erase(without.front().controllers.end() - 1);  // the kinematic_baseline
  try {
    tune_by_quality(f.controller, f.target, without, f.options);
    FAIL() << "tuned without a baseline to compare against";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("'short_offset60'"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("kinematic_baseline"), std::string::npos) << error.what();
  }
  EXPECT_THROW(tune_by_quality(f.controller, f.target, {}, f.options), ConfigError);
  QualityTuningOptions bad = f.options;
  bad.knots = {0};
  try {
    tune_by_quality(f.controller, f.target, f.scenarios, bad);
    FAIL() << "accepted 0 knots";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("knots[] = 0"), std::string::npos) << error.what();
  }
  bad = f.options;
  bad.backends = {"sa", "simplex"};
  try {
    tune_by_quality(f.controller, f.target, f.scenarios, bad);
    FAIL() << "accepted a backend that does not exist";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("backends[] = 'simplex'"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("built: sa"), std::string::npos) << error.what();
  }
  bad = f.options;
  bad.deadline_margins = {0.15, 0.6};
  try {
    tune_by_quality(f.controller, f.target, f.scenarios, bad);
    FAIL() << "accepted a margin of 0.6";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("deadline_margins[] = 0.6"), std::string::npos) << error.what();
  }
  const ControllerConfig baseline = load_controller_config_file(config_file("controllers/kinematic_baseline.yaml"));
  EXPECT_THROW(tune_by_quality(baseline, f.target, f.scenarios, f.options), ConfigError);
  EXPECT_THROW(write_tuned_controller(test_data("does_not_exist.yaml"), TuningCandidate{}, f.target, "", "/dev/null"),
               ConfigError);
}

// --- The real-time report ---

TEST(MeasureRealTime, ReportsStepTimesInTheTargetsMillisecondsAgainstItsBudget) {
  QualityFixture f;
  const std::vector<RealTimeRow> rows = measure_real_time(f.controller, f.target, f.scenarios, &f.clock);
  ASSERT_EQ(rows.size(), 2u);
  for (const RealTimeRow& row : rows) {
    SCOPED_TRACE(row.scenario);
    EXPECT_TRUE(row.completed);
    EXPECT_DOUBLE_EQ(row.budget_ms, 4.0);
    EXPECT_GT(row.step_p50_ms, 0.0);
    EXPECT_LE(row.step_p50_ms, row.step_p99_ms);
    EXPECT_LE(row.step_p99_ms, row.step_max_ms);
    // On the work clock a step stops at its deadline: 2 ms here, 4 ms on a target twice as slow,
    // less the controller's margin (15 %).
    EXPECT_LE(row.step_p99_ms, 4.0);
    EXPECT_GT(row.step_p99_ms, 0.5 * 4.0);
    EXPECT_GT(row.proposals_median, 10.0);
    EXPECT_EQ(row.deadline_misses, 0);
    EXPECT_TRUE(row.passes());
  }
}

// A file tuned for another of the target's periods is measured there, at that period's budget; a
// period the target does not allow is run at the target's.
TEST(MeasureRealTime, RunsAFileAtItsOwnPeriodWhenTheTargetAllowsItElseAtTheTargets) {
  QualityFixture f;
  f.target.other_periods = {{0.025, 0.002}};
  ControllerConfig controller = f.controller;
  controller.mpc.control_period = 0.025;  // dt 0.05: a step of two periods
  const std::vector<RealTimeRow> own = measure_real_time(controller, f.target, {f.scenarios.front()}, &f.clock);
  ASSERT_EQ(own.size(), 1u);
  EXPECT_DOUBLE_EQ(own.front().period_ms, 25.0);
  EXPECT_DOUBLE_EQ(own.front().budget_ms, 2.0);
  EXPECT_LE(own.front().step_p99_ms, 2.0);
  EXPECT_TRUE(own.front().completed);
  f.target.other_periods.clear();
  const std::vector<RealTimeRow> at_target = measure_real_time(controller, f.target, {f.scenarios.front()}, &f.clock);
  EXPECT_DOUBLE_EQ(at_target.front().period_ms, 50.0);
  EXPECT_DOUBLE_EQ(at_target.front().budget_ms, 4.0);
}

TEST(MeasureRealTime, PassesOnlyWithAP99WithinTheBudgetNoMissAndACompletedRun) {
  RealTimeRow row;
  row.completed = true;
  row.budget_ms = 10.0;
  row.step_p99_ms = 10.0;
  EXPECT_TRUE(row.passes());
  row.step_p99_ms = 10.01;
  EXPECT_FALSE(row.passes());
  row.step_p99_ms = 5.0;
  row.deadline_misses = 1;
  EXPECT_FALSE(row.passes());
  row.deadline_misses = 0;
  row.completed = false;
  EXPECT_FALSE(row.passes());
  QualityFixture f;
  const ControllerConfig baseline = load_controller_config_file(config_file("controllers/kinematic_baseline.yaml"));
  EXPECT_THROW(measure_real_time(baseline, f.target, f.scenarios), ConfigError);
}

}  // namespace
}  // namespace swerve
