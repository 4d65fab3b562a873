// Scenarios end to end: short runs of the paper's experiments for every controller, the wear
// saving they exist for, determinism by seed, the summary.json contract, overrides and bad scenario files.
#include "swerve/app/scenario_runner.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "support/fake_clocks.hpp"
#include "swerve/app/run_report.hpp"
#include "support/test_data.hpp"

namespace swerve {
namespace {

std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("swerve_sim_test_" + name);
  std::filesystem::remove_all(dir);
  return dir.string();
}

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The widest angle between two modules' directions of travel (the steering angle, turned round
// when the wheel runs backwards) over a run, among modules commanded at 0.5 rad/s or more, and when.
// A pure translation keeps it near zero; modules driving against each other show it near 180 deg.
struct TravelSpread {
  double angle = 0.0, t = 0.0;
};

TravelSpread widest_travel_spread(const ControllerRun& run) {
  TravelSpread widest;
  for (const StepRecord& r : run.log) {
    for (std::size_t a = 0; a < r.commands.size(); ++a) {
      for (std::size_t b = 0; b < a; ++b) {
        if (std::abs(r.commands[a].wheel_speed) < 0.5 || std::abs(r.commands[b].wheel_speed) < 0.5) continue;
        const double travel_a = r.modules[a].steering_angle + (r.commands[a].wheel_speed < 0.0 ? kPi : 0.0);
        const double travel_b = r.modules[b].steering_angle + (r.commands[b].wheel_speed < 0.0 ? kPi : 0.0);
        const double apart = std::abs(wrap_angle(travel_a - travel_b));
        if (apart > widest.angle) widest = {apart, r.t};
      }
    }
  }
  return widest;
}

// Every shipped vehicle whose steering stops at +-90 deg, crabbing at 90 deg under sensor noise:
// the heading each module needs sits at a stop, on either side of it by the noise. The modules keep
// one side together (hysteresis across the stop), so no two of them ever drive more than 60 deg
// apart. Before, they split between the stops and drove against each other.
TEST(ScenarioRunner, TheBaselineCrabsAt90DegreesOnEveryVehicleWithEndStopsThereWithoutModulesFighting) {
  const std::string source = file_text(testing::app_data_file("crab90_end_stops_baseline.yaml"));
  int vehicles = 0;
  for (const char* vehicle : {"carrier_6module", "carrier_8module", "paper_ms_agv"}) {
    SCOPED_TRACE(vehicle);
    std::string text = source;
    const std::string from = "carrier_6module.yaml";
    text.replace(text.find(from), from.size(), std::string(vehicle) + ".yaml");
    const std::string path = testing::app_data_file(std::string("crab90_end_stops_") + vehicle + ".generated.yaml");
    std::ofstream(path) << text;
    const ScenarioConfig scenario = load_scenario_config_file(path);
    std::filesystem::remove(path);
    const ModuleLimits& limits = scenario.vehicle.layout.limits();
    ASSERT_TRUE(limits.has_steering_end_stops());
    ASSERT_NEAR(limits.max_steering_angle, kPi / 2, 1e-9);
    ++vehicles;
    const std::vector<ControllerRun> runs = run_scenario(scenario);
    ASSERT_EQ(runs.size(), 1u);
    const ControllerRun& run = runs[0];
    ASSERT_TRUE(run.completed) << run.failure;
    const TravelSpread spread = widest_travel_spread(run);
    EXPECT_LT(spread.angle, kPi / 3) << "modules drove " << spread.angle * 180.0 / kPi << " deg apart at t = " << spread.t
                                     << " s";
    // The heading holds (before: 1.7 deg RMS on the carriers). The position does not track well:
    // the paper's baseline drives at the inverse-kinematics speed while its modules turn the first
    // 90 deg, and the 0.2-0.3 m it drifts sideways then can only be corrected by a quarter turn.
    EXPECT_LT(run.metrics.heading_rmse_rad, 1.5 * kPi / 180.0);
    EXPECT_LT(run.metrics.tracking_rmse_m, 1.0);
    std::printf("[          ] %s: RMSE %.1f mm, heading %.2f deg, wear %.1f J\n", vehicle,
                1e3 * run.metrics.tracking_rmse_m, run.metrics.heading_rmse_rad * 180.0 / kPi, run.metrics.wear_total);
  }
  EXPECT_EQ(vehicles, 3);
}

TEST(ScenarioRunner, ShortPaperScenarioRunsEveryControllerWithFiniteMetrics) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  const std::vector<ControllerRun> runs = run_scenario(scenario);
  ASSERT_EQ(runs.size(), 3u);
  for (const ControllerRun& run : runs) {
    SCOPED_TRACE(run.name);
    EXPECT_TRUE(run.completed) << run.failure;
    EXPECT_EQ(run.metrics.steps, 30);  // 1.5 s at 20 Hz
    EXPECT_TRUE(std::isfinite(run.metrics.tracking_rmse_m));
    EXPECT_GT(run.metrics.wear_total, 0.0);
    EXPECT_EQ(run.metrics.wear_per_module.size(), 10u);
    for (const StepRecord& r : run.log) {
      for (const ModuleCommand& c : r.commands) {
        ASSERT_TRUE(std::isfinite(c.steering_rate) && std::isfinite(c.wheel_speed));
      }
    }
  }
  EXPECT_EQ(runs[0].kind, ControllerKind::kWearMpc);
  EXPECT_GT(runs[0].wear_weight, 0.0);
  EXPECT_EQ(runs[1].wear_weight, 0.0);  // dynamic_no_wear: configuration only
  EXPECT_EQ(runs[2].kind, ControllerKind::kKinematicBaseline);
}

// What the project exists for: from rest with the reference heading 60 deg off the direction of
// travel (the paper's hard start, 8 s of it), the wear-aware MPC wears the tires much less than the
// kinematic baseline. The MPC is the default controller with an SA iteration cap in place of its
// 20 ms clock (iteration_limited_default_mpc.yaml), run on a clock that advances 10 us per read, so
// no solve ever meets its deadline and the result depends on the seeds alone, not on the machine or
// its load. Measured reductions on the wall clock: 53-81 % over noise seeds 1-10 (idle; identical
// with one core busy), 59-80 % on the seeds below with both cores busy (some solves then hit the
// deadline). 30 % leaves a margin of 20+ points under the worst of those. (Over the first 1.5 s alone the
// MPC wears more than the baseline: it is still turning all ten wheels; the saving comes after.)
constexpr double kMinimumWearReductionPct = 30.0;

TEST(ScenarioRunner, WearMpcWearsFarLessThanTheKinematicBaselineFromA60DegreeOffset) {
  const ScenarioConfig base = load_scenario_config_file(testing::app_data_file("offset60_from_rest.yaml"));
  for (const std::uint64_t seed : {7u, 8u, 9u}) {
    SCOPED_TRACE(seed);
    RunOverrides overrides;
    overrides.seed = seed;
    const testing::WorkClock clock(10e-6);
    const std::vector<ControllerRun> runs = run_scenario(apply_overrides(base, overrides), {}, &clock);
    ASSERT_EQ(runs.size(), 2u);
    ASSERT_EQ(runs[0].name, "wear_mpc");
    ASSERT_EQ(runs[1].name, "kinematic_baseline");
    ASSERT_TRUE(runs[0].completed && runs[1].completed);
    const double reduction = wear_reduction_pct(runs[0].metrics, runs[1].metrics);
    std::printf(
        "[          ] seed %llu: wear %.3f vs %.3f, reduction %.1f %%, rmse %.4f vs %.4f m, p99 solve %.1f "
        "ms\n",
        static_cast<unsigned long long>(seed), runs[0].metrics.wear_total, runs[1].metrics.wear_total,
        reduction, runs[0].metrics.tracking_rmse_m, runs[1].metrics.tracking_rmse_m,
        runs[0].metrics.solve_time_p99_ms);
    EXPECT_GT(reduction, kMinimumWearReductionPct);
  }
}

// The shipped fault scenario: module 0's steering sticks at 6.6 s in a 1 m lane change at 1 m/s.
// Each controller, not told, finds it within 5 periods and drives on: no safe stop, no other
// module taken as stuck. The wear-aware one then tracks first: 4.3 mm RMSE after detection on this
// machine (goal: 5 cm); with the wear still priced it had left the path by 1.3 m. Told at onset
// (announced), the controllers know it in the same period.
TEST(ScenarioRunner, AStuckSteeringMidLaneChangeIsFoundWithinFivePeriodsAndTheLaneStillTracked) {
  const ScenarioConfig shipped =
      load_scenario_config_file(std::string(SWERVE_SOURCE_DIR) + "/configs/scenarios/faults/agv_stuck_steering.yaml");
  RunOverrides overrides;
  overrides.controllers = {"wear_mpc", "kinematic_baseline"};
  for (const bool announced : {false, true}) {
    SCOPED_TRACE(announced ? "announced" : "detected");
    ScenarioConfig scenario = apply_overrides(shipped, overrides);
    scenario.simulator.faults[0].announced = announced;
    const testing::WorkClock clock(10e-6);
    const std::vector<ControllerRun> runs = run_scenario(scenario, {}, &clock);
    ASSERT_EQ(runs.size(), 2u);
    for (const ControllerRun& run : runs) {
      SCOPED_TRACE(run.name);
      ASSERT_TRUE(run.completed) << run.failure;
      const RunMetrics& m = run.metrics;
      std::printf("[          ] %s, %s: found after %d periods, RMSE after %.4f m, wear %.1f J\n", run.name.c_str(),
                  announced ? "announced" : "detected", m.fault_detection_cycles, m.tracking_rmse_after_fault_known_m,
                  m.wear_total);
      EXPECT_NEAR(m.fault_onset_s, 6.6, 1e-9);
      EXPECT_GE(m.fault_detection_cycles, 0);
      EXPECT_LE(m.fault_detection_cycles, announced ? 0 : 5);
      EXPECT_EQ(m.false_fault_alarms, 0);
      EXPECT_EQ(m.safe_stops, 0);
      EXPECT_LT(m.tracking_rmse_after_fault_known_m, 0.05);
      // The stuck module is never steered once known.
      for (const StepRecord& r : run.log) {
        if ((r.known_faults & 1u) != 0) {
          ASSERT_EQ(r.commands[0].steering_rate, 0.0) << "t = " << r.t;
        }
      }
    }
  }
}

// The shipped fault scenario `file` (configs/scenarios/faults/) run by wear_mpc and the kinematic
// baseline on a work clock, as shipped and with its faults taken out.
std::pair<std::vector<ControllerRun>, std::vector<ControllerRun>> runs_with_and_without_faults(const std::string& file) {
  const ScenarioConfig shipped =
      load_scenario_config_file(std::string(SWERVE_SOURCE_DIR) + "/configs/scenarios/faults/" + file);
  RunOverrides overrides;
  overrides.controllers = {"wear_mpc", "kinematic_baseline"};
  const ScenarioConfig faulty = apply_overrides(shipped, overrides);
  ScenarioConfig healthy = faulty;
  healthy.simulator.faults.clear();
  const testing::WorkClock clock(10e-6);
  return {run_scenario(faulty, {}, &clock), run_scenario(healthy, {}, &clock)};
}

// The shipped dead-drive scenario: module 2 of the 8-module carrier loses its drive at 1.0 s, while
// it still accelerates into a 1 m lane change, and nobody is told. The other seven carry its
// traction: on this machine 4.2 mm RMSE against 4.1 mm without the fault (goal: at most twice).
TEST(ScenarioRunner, ADeadDriveOnTheCarrierKeepsTheTrackingWithinTwiceTheFaultFreeRuns) {
  const auto [with_fault, without] = runs_with_and_without_faults("carrier_dead_drive.yaml");
  ASSERT_EQ(with_fault.size(), 2u);
  for (std::size_t j = 0; j < with_fault.size(); ++j) {
    SCOPED_TRACE(with_fault[j].name);
    ASSERT_TRUE(with_fault[j].completed && without[j].completed);
    const double ratio = with_fault[j].metrics.tracking_rmse_m / without[j].metrics.tracking_rmse_m;
    std::printf("[          ] %s: RMSE %.4f m with the dead drive, %.4f m without (x%.2f), wear %.2f vs %.2f\n",
                with_fault[j].name.c_str(), with_fault[j].metrics.tracking_rmse_m, without[j].metrics.tracking_rmse_m,
                ratio, with_fault[j].metrics.wear_total, without[j].metrics.wear_total);
    EXPECT_LE(ratio, 2.0);
    EXPECT_EQ(with_fault[j].metrics.safe_stops, 0);
    EXPECT_EQ(with_fault[j].metrics.false_fault_alarms, 0);  // nor is a healthy steering taken as stuck
    EXPECT_GT(std::abs(with_fault[j].metrics.wear_total - without[j].metrics.wear_total), 0.1);  // the fault acted
  }
}

// The shipped wet-patch scenario, cut at 20 s (the vehicle is wholly on the patch from 13.55 s):
// the estimating controller's grip is within 10 % of the floor's within 2 s of that, and its
// prediction misses the plant by less than half of what the controller that keeps the dry mu
// misses (measured on this machine: settled before the whole vehicle was on, 1.7 % worst error;
// position prediction error a fifth of the dry mu's).
TEST(ScenarioRunner, TheGripOfAWetPatchIsEstimatedWithinTenPercentAndMendsThePrediction) {
  ScenarioConfig scenario = load_scenario_config_file(std::string(SWERVE_SOURCE_DIR) +
                                                      "/configs/scenarios/friction/curve_wet_patch.yaml");
  RunOverrides overrides;
  overrides.controllers = {"wear_mpc", "wear_mpc_nominal"};
  scenario = apply_overrides(scenario, overrides);
  scenario.duration = 20.0;
  const testing::WorkClock clock(10e-6);
  const std::vector<ControllerRun> runs = run_scenario(scenario, {}, &clock);
  ASSERT_EQ(runs.size(), 2u);
  ASSERT_TRUE(runs[0].completed && runs[1].completed);
  const RunMetrics& m = runs[0].metrics;
  EXPECT_NEAR(m.friction_change_complete_s, 13.55, 0.051);
  ASSERT_GE(m.friction_settle_after_complete_s, 0.0) << "never settled";
  EXPECT_LE(m.friction_settle_after_complete_s, 2.0);
  EXPECT_LE(m.friction_error_after_settle_max_pct, 10.0);
  EXPECT_LT(runs[1].metrics.friction_settle_after_change_s, 0.0);  // the dry mu never comes near 0.4
  const auto mean_miss = [](const ControllerRun& run) {
    double sum = 0.0;
    int count = 0;
    for (const StepRecord& r : run.log) {
      if (r.t >= 15.0 && std::isfinite(r.prediction_position_error_m)) sum += r.prediction_position_error_m, ++count;
    }
    return count > 0 ? sum / count : std::nan("");
  };
  std::printf("[          ] settled %.2f s after the whole vehicle was on, worst %.1f %%; prediction miss %.2g vs %.2g m\n",
              m.friction_settle_after_complete_s, m.friction_error_after_settle_max_pct, mean_miss(runs[0]),
              mean_miss(runs[1]));
  EXPECT_LT(mean_miss(runs[0]), 0.5 * mean_miss(runs[1]));
}

// The shipped lost-encoder scenario: module 1's steering angle is measured as NaN from 6.6 s in a
// 1 m lane change at 1 m/s. Each controller stands in for it by the rates it sends and drives on:
// no safe stop (a NaN angle used to reject the whole measurement), the module marked in the
// period after its first NaN, the lane tracked as without the fault.
TEST(ScenarioRunner, ALostSteeringEncoderIsStoodInForAndTheLaneStillTracked) {
  const auto [with_fault, without] = runs_with_and_without_faults("agv_lost_steering_sensor.yaml");
  ASSERT_EQ(with_fault.size(), 2u);
  for (std::size_t j = 0; j < with_fault.size(); ++j) {
    SCOPED_TRACE(with_fault[j].name);
    ASSERT_TRUE(with_fault[j].completed && without[j].completed);
    const RunMetrics& m = with_fault[j].metrics;
    std::printf("[          ] %s: known after %d periods, RMSE %.4f m (fault-free %.4f m), %d safe stops\n",
                with_fault[j].name.c_str(), m.fault_detection_cycles, m.tracking_rmse_m,
                without[j].metrics.tracking_rmse_m, m.safe_stops);
    EXPECT_EQ(m.safe_stops, 0);
    EXPECT_EQ(m.false_fault_alarms, 0);
    EXPECT_GE(m.fault_detection_cycles, 0);
    EXPECT_LE(m.fault_detection_cycles, 1);
    EXPECT_LE(m.tracking_rmse_m, 1.5 * without[j].metrics.tracking_rmse_m);
    EXPECT_EQ(with_fault[j].module_faults[1], ModuleFault::kSteeringSensorLost);
  }
}

TEST(ScenarioRunner, IdenticalSeedsWriteIdenticalLogs) {
  // The controllers run on a clock that advances 10 us per read (SA reads it once per proposal),
  // so the deadline and SA's time-driven cooling are the same on any machine, under any load and
  // in a sanitizer build: the logs must agree to the last digit, timing columns included.
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("deterministic.yaml"));
  const std::string a = temp_dir("det_a"), b = temp_dir("det_b"), c = temp_dir("det_c");
  const testing::WorkClock clock(10e-6);
  write_run_outputs(scenario, run_scenario(scenario, {}, &clock), a);
  write_run_outputs(scenario, run_scenario(scenario, {}, &clock), b);
  RunOverrides other_seed;
  other_seed.seed = 12;
  const ScenarioConfig reseeded = apply_overrides(scenario, other_seed);
  write_run_outputs(reseeded, run_scenario(reseeded, {}, &clock), c);
  for (const char* name : {"/wear_mpc.csv", "/kinematic_baseline.csv"}) {
    SCOPED_TRACE(name);
    const std::string first = file_text(a + name);
    EXPECT_GT(first.size(), 1000u);
    EXPECT_EQ(first, file_text(b + name));
    EXPECT_NE(first, file_text(c + name));
  }
}

// Splits one CSV line at its commas, keeping empty cells.
std::vector<std::string> csv_cells(const std::string& line) {
  std::vector<std::string> cells(1);
  for (char c : line) {
    if (c == ',') {
      cells.emplace_back();
    } else {
      cells.back() += c;
    }
  }
  return cells;
}

// The optimiser's predicted costs in the log obey what every backend promises: nothing worse than
// the best initial guess, and a total of at least its tracking and wear parts. The baseline runs no
// optimiser and leaves them empty.
TEST(ScenarioRunner, TheLogCarriesEachPlansPredictedCostAndTheBestGuessItStartedFrom) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("deterministic.yaml"));
  const std::string dir = temp_dir("plan_cost");
  const testing::WorkClock clock(10e-6);
  write_run_outputs(scenario, run_scenario(scenario, {}, &clock), dir);
  for (const char* name : {"/wear_mpc.csv", "/kinematic_baseline.csv"}) {
    SCOPED_TRACE(name);
    std::istringstream lines(file_text(dir + name));
    std::string line;
    ASSERT_TRUE(std::getline(lines, line));
    const std::vector<std::string> header = csv_cells(line);
    const auto column = [&](const std::string& key) {
      const auto at = std::find(header.begin(), header.end(), key);
      EXPECT_NE(at, header.end()) << key;
      return static_cast<std::size_t>(at - header.begin());
    };
    const std::size_t tracking = column("plan_tracking_cost"), wear = column("plan_wear_cost"),
                      total = column("plan_cost"), guess = column("initial_guess_cost"),
                      solve_time = column("solve_time_ms");
    int solved = 0;
    while (std::getline(lines, line)) {
      const std::vector<std::string> cells = csv_cells(line);
      ASSERT_EQ(cells.size(), header.size()) << line;
      if (cells[solve_time].empty() || cells[guess].empty()) {
        EXPECT_TRUE(cells[tracking].empty() && cells[wear].empty() && cells[total].empty() && cells[guess].empty());
        continue;
      }
      ++solved;
      const double plan = std::stod(cells[total]);
      // The log prints 9 significant digits: the parts' rounding may add up past the total's.
      EXPECT_GE(plan * (1.0 + 1e-8) + 1e-12, std::stod(cells[tracking]) + std::stod(cells[wear]));
      EXPECT_LE(plan, std::stod(cells[guess]) * (1.0 + 1e-12)) << line;
    }
    EXPECT_EQ(solved > 0, std::string(name) == "/wear_mpc.csv");
  }
}

TEST(ScenarioRunner, SummaryJsonHasEveryDocumentedKeyWithItsType) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  const std::string dir = temp_dir("summary");
  write_run_outputs(scenario, run_scenario(scenario), dir);
  std::ifstream in(dir + "/summary.json");
  ASSERT_TRUE(in) << "summary.json was not written";
  const nlohmann::json s = nlohmann::json::parse(in);
  EXPECT_TRUE(s.at("scenario").is_string());
  EXPECT_TRUE(s.at("vehicle").is_string());
  EXPECT_TRUE(s.at("seed").is_number_integer());
  EXPECT_TRUE(s.at("module_positions_m").is_array());
  const nlohmann::json& controllers = s.at("controllers");
  for (const char* name : {"wear_mpc", "dynamic_no_wear", "kinematic_baseline"}) {
    SCOPED_TRACE(name);
    const nlohmann::json& c = controllers.at(name);
    for (const char* key : {"tracking_rmse_m", "tracking_max_m", "heading_rmse_rad", "wear_total",
                            "frictional_energy_J", "solve_time_p50_ms", "solve_time_p99_ms"}) {
      EXPECT_TRUE(c.at(key).is_number()) << key;
    }
    EXPECT_TRUE(c.at("wear_per_module").is_array());
    EXPECT_EQ(c.at("wear_per_module").size(), 10u);
    EXPECT_TRUE(c.at("wear_units").is_string());
    EXPECT_TRUE(c.at("deadline_misses").is_number_integer());
    EXPECT_TRUE(c.at("late_solves").is_number_integer());
    EXPECT_TRUE(c.at("fallbacks").is_number_integer());
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + c.at("log_csv").get<std::string>()));
  }
  const nlohmann::json& comparison = s.at("comparison");
  for (const char* key : {"wear_reduction_pct", "tracking_rmse_ratio", "wear_reduction_vs_no_wear_pct"}) {
    EXPECT_TRUE(comparison.at(key).is_number()) << key;
  }
  EXPECT_DOUBLE_EQ(comparison.at("paper_wear_reduction_pct").get<double>(), 65.2);
  // The comparison is computed from the controllers' own numbers.
  const double w = controllers.at("wear_mpc").at("wear_total"), b = controllers.at("kinematic_baseline").at("wear_total");
  EXPECT_NEAR(comparison.at("wear_reduction_pct").get<double>(), 100.0 * (b - w) / b, 1e-9);
  EXPECT_FALSE(std::filesystem::exists(dir + "/.summary.json.tmp"));
}

TEST(ScenarioRunner, OverridesPickControllersAndRejectUnknownNames) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_offset60.yaml"));
  RunOverrides only_baseline;
  only_baseline.controllers = {"kinematic_baseline"};
  EXPECT_EQ(apply_overrides(scenario, only_baseline).controllers.size(), 1u);
  RunOverrides unknown;
  unknown.controllers = {"no_such_controller"};
  try {
    apply_overrides(scenario, unknown);
    FAIL() << "an unknown controller name was accepted";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("no_such_controller"), std::string::npos) << error.what();
  }
  RunOverrides unbuilt;
  unbuilt.backend = "no_such_backend";
  EXPECT_THROW(apply_overrides(scenario, unbuilt), ConfigError);
  RunOverrides sweep;
  sweep.wear_weight = 7.0;
  const ScenarioConfig swept = apply_overrides(scenario, sweep);
  EXPECT_EQ(swept.controllers[0].config.mpc.wear_weight, 7.0);
  EXPECT_EQ(swept.controllers[1].config.mpc.wear_weight, 0.0);  // the no-wear comparison stays at 0
}

void expect_config_error(const std::string& file, const std::string& expected) {
  try {
    load_scenario_config_file(testing::app_data_file(file));
    FAIL() << file << " was accepted";
  } catch (const ConfigError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(file), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << message;
  }
}

TEST(ScenarioConfig, BadFilesNameTheFileTheKeyPathAndTheValue) {
  expect_config_error("typo_scenario.yaml", "scenario.reference.speeed: unknown key");
  expect_config_error("missing_vehicle.yaml", "scenario.vehicle");
  expect_config_error("negative_duration.yaml", "scenario.duration = -3");
  // A controller's name becomes its log's file name: no path may escape the output directory.
  expect_config_error("bad_controller_name.yaml", "scenario.controllers[0].name: '../escape'");
  // Found by tests/fuzz/config_fuzzer (it ran out of memory reading /dev/zero as the CSV).
  expect_config_error("device_csv_reference.yaml",
                      "scenario.reference.file: cannot load: /dev/zero: a character device, not a regular file");
  expect_config_error("bad_measurement_filter.yaml", "scenario.measurement_filter.pose_gain = 0");
  expect_config_error("fault_unknown_module.yaml", "scenario.simulator.faults[0].module");
  expect_config_error("fault_unknown_kind.yaml", "scenario.simulator.faults[0].kind");
  expect_config_error("fault_unknown_kind.yaml", "flat_tire");
  expect_config_error("fault_after_the_run.yaml", "scenario.simulator.faults[0].at = 4");
  expect_config_error("fault_twice_on_a_module.yaml", "scenario.simulator.faults[1].module = 1");
  expect_config_error("fault_in_no_period.yaml", "scenario.simulator.faults[0].at = 3.99: no control period starts");
  expect_config_error("friction_patch_no_grip.yaml", "scenario.simulator.friction_patches[0].mu = 0");
  expect_config_error("friction_patch_reversed.yaml", "scenario.simulator.friction_patches[0].max = [-2, 1]: must be greater");
  expect_config_error("friction_patch_overlap.yaml", "scenario.simulator.friction_patches[1]: overlaps friction_patches[0]");
  expect_config_error("friction_estimation_on_baseline.yaml", "only a wear_mpc controller has one");
  expect_config_error("wear_balancing_on_baseline.yaml", "wear_balancing: only a wear_mpc controller has one");
  expect_config_error("initial_wear_wrong_size.yaml",
                      "scenario.simulator.initial_module_wear: expected a list of 4 numbers, got 3");
  expect_config_error("initial_wear_negative.yaml", "scenario.simulator.initial_module_wear[2] = -3: must be >= 0");
  expect_config_error("friction_announced_outside_bounds.yaml",
                      "scenario.simulator.friction_patches[0].mu = 0.1: announced, it is 0.125x the tire's mu");
}

TEST(ScenarioConfig, AScenarioWideMeasurementFilterReachesEveryController) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("filtered_crab.yaml"));
  ASSERT_EQ(scenario.controllers.size(), 2u);
  for (const ScenarioController& c : scenario.controllers) {
    SCOPED_TRACE(c.name);
    EXPECT_EQ(c.config.mpc.measurement_filter.pose_gain, 0.3);
    EXPECT_EQ(c.config.mpc.measurement_filter.steering_gain, 0.4);
    EXPECT_EQ(c.config.baseline.measurement_filter.pose_gain, 0.3);
    EXPECT_EQ(c.config.baseline.measurement_filter.steering_gain, 0.4);
  }
}

TEST(RunReport, AnUnwritableOutputDirectoryIsAClearError) {
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_curve_baseline.yaml"));
  const std::vector<ControllerRun> runs;  // nothing to write but the summary
  EXPECT_THROW(write_run_outputs(scenario, runs, "/proc/swerve_cannot_write_here"), std::runtime_error);
}

TEST(ScenarioRunner, ARepeatedControllerOverrideIsAnOverrideError) {
  // Running a controller twice would leave one summary.json entry for two runs.
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_curve_baseline.yaml"));
  RunOverrides twice;
  twice.controllers = {"kinematic_baseline", "kinematic_baseline"};
  try {
    apply_overrides(scenario, twice);
    FAIL() << "a repeated controller name was accepted";
  } catch (const OverrideError& error) {
    EXPECT_NE(std::string(error.what()).find("--controllers: 'kinematic_baseline' is given twice"), std::string::npos)
        << error.what();
  }
  RunOverrides unknown;
  unknown.controllers = {"no_such_controller"};
  EXPECT_THROW(apply_overrides(scenario, unknown), OverrideError);
}

TEST(ScenarioRunner, ABadToleranceOverrideIsAnOverrideErrorEvenWithoutAWearAwareController) {
  // Like --backend: a typo must not pass just because the chosen controllers would ignore it.
  const ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_curve_baseline.yaml"));
  RunOverrides bad;
  TrackingTolerance tolerance;
  tolerance.position = -0.05;
  tolerance.heading = 0.01;
  bad.tracking_tolerance = tolerance;
  try {
    apply_overrides(scenario, bad);
    FAIL() << "a negative tolerance was accepted";
  } catch (const OverrideError& error) {
    EXPECT_NE(std::string(error.what()).find("--tolerance: "), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("-0.05"), std::string::npos) << error.what();
  }
}

TEST(ScenarioConfig, StepCountIsBoundedInsteadOfOverflowing) {
  ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("short_curve_baseline.yaml"));
  EXPECT_EQ(scenario.steps(), 40);  // 2 s at 50 ms
  scenario.duration = kMaxScenarioSteps * scenario.simulator.control_period;
  EXPECT_EQ(scenario.steps(), kMaxScenarioSteps);
  scenario.duration = 1e9;  // 2e10 steps: more than an int holds
  EXPECT_THROW(scenario.steps(), ConfigError);
}

TEST(RunReport, OutputDirectoryIsCheckedBeforeAnythingRuns) {
  const std::string file = testing::app_data_file("short_curve_baseline.yaml");
  try {
    prepare_output_directory(file);  // an existing regular file cannot be the output directory
    FAIL() << "a regular file was accepted as the output directory";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(file + ": cannot create the output directory"), std::string::npos)
        << error.what();
  }
  const std::string fresh = std::string(SWERVE_BINARY_DIR) + "/run_report_test_out/nested";
  std::filesystem::remove_all(fresh);
  EXPECT_NO_THROW(prepare_output_directory(fresh));
  EXPECT_TRUE(std::filesystem::is_directory(fresh));
  EXPECT_TRUE(std::filesystem::is_empty(fresh));  // the probe file is gone
}

// Issue 14 item 7: a measurement one period old (stamped as such) must not make the baseline's
// deadbeat steering chase its own delayed effect. The delayed run's wear stays within 1.5x of the
// undelayed run's; without the latency compensation it was ~500x (0.4 J -> 228 J on 16 s).
TEST(ScenarioRunner, AOnePeriodMeasurementDelayDoesNotMakeTheBaselineSteeringOscillate) {
  ScenarioConfig delayed = load_scenario_config_file(testing::app_data_file("crab_delayed_baseline.yaml"));
  ASSERT_EQ(delayed.simulator.measurement_delay_steps, 1);
  ScenarioConfig prompt = delayed;
  prompt.simulator.measurement_delay_steps = 0;
  const ControllerRun with_delay = run_controller(delayed, delayed.controllers[0]);
  const ControllerRun without_delay = run_controller(prompt, prompt.controllers[0]);
  ASSERT_TRUE(with_delay.completed && without_delay.completed);
  ASSERT_GT(without_delay.metrics.wear_total, 0.0);
  EXPECT_LT(with_delay.metrics.wear_total, 1.5 * without_delay.metrics.wear_total);
  EXPECT_LT(with_delay.metrics.tracking_rmse_m, 1.5 * without_delay.metrics.tracking_rmse_m + 0.005);
  // No sustained steering oscillation: after the start-up (the modules turn by 90 deg in the first
  // ~1.3 s) the commanded steering rates stay small, and the steering travels about as far as
  // without the delay (the oscillation was +-3 rad/s).
  const auto steering_travel = [](const ControllerRun& run) {
    double travel = 0.0;
    for (std::size_t k = 1; k < run.log.size(); ++k) {
      for (std::size_t i = 0; i < run.log[k].modules.size(); ++i) {
        travel += std::abs(wrap_angle(run.log[k].modules[i].steering_angle - run.log[k - 1].modules[i].steering_angle));
      }
    }
    return travel;
  };
  EXPECT_LT(steering_travel(with_delay), 1.2 * steering_travel(without_delay));
  double largest_rate = 0.0;
  for (const StepRecord& r : with_delay.log) {
    if (r.t < 1.5) continue;
    for (const ModuleCommand& c : r.commands) largest_rate = std::max(largest_rate, std::abs(c.steering_rate));
  }
  EXPECT_LT(largest_rate, 0.5);
}

// Issue 14 item 7: with sensor noise and a one-period delay, the crab's start puts every module
// at the flip boundary (90 deg off). The modules must not split there, half of them turning each
// way round with their wheels driving against each other: while they drive, their directions of
// travel stay within 60 deg of each other (a pure translation; measured at most 29 deg over seeds
// 1-8, against 156-173 deg in 4 of 5 seeds when each module decided its flip alone).
TEST(ScenarioRunner, UnderSensorNoiseTheBaselinesModulesNeverDriveAgainstEachOther) {
  ScenarioConfig scenario = load_scenario_config_file(testing::app_data_file("crab_noisy_baseline.yaml"));
  for (const std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    scenario.simulator.seed = seed;
    const ControllerRun run = run_controller(scenario, scenario.controllers[0]);
    ASSERT_TRUE(run.completed) << run.failure;
    const TravelSpread spread = widest_travel_spread(run);
    EXPECT_LT(spread.angle, kPi / 3) << "modules drove " << spread.angle * 180.0 / kPi << " deg apart at t = " << spread.t
                                     << " s";
  }
}

}  // namespace
}  // namespace swerve
