// The operating envelope generator: draws repeat bit for bit from their seed and stay inside the
// draw space, every family writes a scenario the normal loader accepts, bad options are refused
// naming the field and value, goals are judged as stated, and a failed draw is reported, not dropped.
#include "swerve/app/envelope.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "swerve/app/scenario_config.hpp"
#include "swerve/control/latency_compensator.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_layout.hpp"

namespace swerve {
namespace {

namespace fs = std::filesystem;

constexpr double kDegree = kPi / 180.0;

EnvelopeOptions shipped_options(const std::string& out_dir) {
  EnvelopeOptions options;
  options.out_dir = out_dir;
  options.controller_file = std::string(SWERVE_SOURCE_DIR) + "/configs/controllers/default.yaml";
  options.baseline_file = std::string(SWERVE_SOURCE_DIR) + "/configs/controllers/kinematic_baseline.yaml";
  return options;
}

// A directory of this test's own (ctest runs tests in parallel processes).
std::string scratch_dir() {
  const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  const fs::path dir =
      fs::temp_directory_path() / ("swerve_envelope_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string();
}

std::string error_of(const EnvelopeOptions& options) {
  try {
    options.validate();
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "";
}

TEST(Envelope, SameSeedAndIndexGiveTheSameDrawBitForBit) {
  const std::vector<ReferenceFamily>& families = all_reference_families();
  for (int index = 0; index < static_cast<int>(families.size()); ++index) {
    SCOPED_TRACE(index);
    const Draw a = draw_case(42, index, families);
    const Draw b = draw_case(42, index, families);
    EXPECT_EQ(vehicle_yaml(a), vehicle_yaml(b));
    EXPECT_EQ(scenario_yaml(a), scenario_yaml(b));
    EXPECT_EQ(reference_csv(a), reference_csv(b));
    EXPECT_EQ(a.duration, b.duration);
  }
}

TEST(Envelope, TurnThenGoTurnsInPlaceThenDrivesAStraightLegAtTheHeadingTheTurnLeft) {
  for (int index = 0; index < 6; ++index) {
    SCOPED_TRACE(index);
    const Draw d = draw_case(5, index, {ReferenceFamily::kTurnThenGo});
    const auto& rows = d.reference.rows;
    ASSERT_GT(rows.size(), 100u);
    // Until the leg starts the vehicle stands (it only turns); from then on it no longer turns (to
    // within the turn's last row, where the leg follows at once).
    const double turned = rows.back()[3] - rows[0][3];
    EXPECT_GT(std::abs(turned), 1.0 * kDegree);
    std::size_t k = 0;
    while (k < rows.size() && std::hypot(rows[k][4], rows[k][5]) == 0.0) ++k;
    ASSERT_LT(k, rows.size());
    for (; k < rows.size(); ++k) {
      EXPECT_NEAR(rows[k][6], 0.0, 1e-6) << "t = " << rows[k][0];
      EXPECT_NEAR(rows[k][3] - rows[0][3], turned, 1e-6);
      if (std::hypot(rows[k][4], rows[k][5]) > 1e-6) {
        // The leg runs along the draw's direction in the world: at minus the turn in the body frame.
        EXPECT_NEAR(std::remainder(std::atan2(rows[k][5], rows[k][4]) + turned, 2.0 * kPi), 0.0, 1e-6);
      }
    }
  }
}

TEST(Envelope, ADifferentSeedGivesDifferentDraws) {
  const Draw a = draw_case(1, 0, all_reference_families());
  const Draw b = draw_case(2, 0, all_reference_families());
  EXPECT_NE(vehicle_yaml(a) + scenario_yaml(a), vehicle_yaml(b) + scenario_yaml(b));
}

TEST(Envelope, FamiliesTakeTurnsByIndex) {
  const std::vector<ReferenceFamily> families = {ReferenceFamily::kCrab, ReferenceFamily::kStopAndGo};
  EXPECT_EQ(draw_case(3, 0, families).family, ReferenceFamily::kCrab);
  EXPECT_EQ(draw_case(3, 1, families).family, ReferenceFamily::kStopAndGo);
  EXPECT_EQ(draw_case(3, 2, families).family, ReferenceFamily::kCrab);
}

TEST(Envelope, DrawsStayInsideTheDrawSpace) {
  const std::vector<ReferenceFamily>& families = all_reference_families();
  for (int index = 0; index < 220; ++index) {
    SCOPED_TRACE(index);
    const Draw d = draw_case(9, index, families);
    const VehicleDraw& v = d.vehicle;
    EXPECT_GE(v.modules(), 2);
    EXPECT_LE(v.modules(), 16);
    EXPECT_TRUE(v.layout == "triangle" ? v.modules() == 3 : v.modules() == 2 * v.axles);
    EXPECT_GE(v.mass, 50.0);
    EXPECT_LE(v.mass, 5000.0);
    EXPECT_NEAR(
        v.yaw_inertia,
        v.mass * (v.footprint_length * v.footprint_length + v.footprint_width * v.footprint_width) / 12.0,
        0.051);
    EXPECT_TRUE(v.steering_limit == kPi / 2.0 || v.steering_limit == kPi);
    EXPECT_GE(v.mu, 0.3);
    EXPECT_LE(v.mu, 1.0);
    EXPECT_GE(v.wheel_radius, 0.08);
    EXPECT_LE(v.wheel_radius, 0.35);
    for (const double tau : {v.steering_time_constant, v.drive_time_constant}) {
      EXPECT_GE(tau, 0.02);
      EXPECT_LE(tau, 0.1);
    }
    EXPECT_GE(v.drive_speed, 1.5);
    EXPECT_LE(v.drive_speed, 3.0);
    EXPECT_GE(v.drive_acceleration, 0.5);
    EXPECT_LE(v.drive_acceleration, 2.0);
    EXPECT_GE(v.steering_rate, 1.0);
    EXPECT_LE(v.steering_rate, 4.0);

    const ConditionsDraw& c = d.conditions;
    EXPECT_GE(c.control_period, 0.010);
    EXPECT_LE(c.control_period, 0.050);
    EXPECT_DOUBLE_EQ(c.solve_budget, 0.4 * c.control_period);
    EXPECT_LE(c.latency, 0.150 + 1e-12);
    EXPECT_LE(c.measurement_delay_steps, LatencyCompensator::kMaxSteps);
    EXPECT_DOUBLE_EQ(c.latency, c.measurement_delay_steps * c.control_period);

    const ReferenceDraw& r = d.reference;
    EXPECT_EQ(d.family, families[static_cast<std::size_t>(index) % families.size()]);
    EXPECT_GT(r.duration, 5.0);
    EXPECT_LE(r.speed, 0.8 * v.drive_speed + 1e-9);
    EXPECT_LE(r.acceleration, v.drive_acceleration + 1e-9);
    EXPECT_EQ(d.duration, r.duration);
    for (const std::array<double, 7>& row : r.rows) {
      EXPECT_LE(std::hypot(row[4], row[5]), 0.8 * v.drive_speed + 1e-9);
    }
  }
}

TEST(Envelope, AVehicleWithEndStopsIsNeverAskedToRollAcrossThem) {
  // Heading changes and S-curves on +-90 deg vehicles keep the body's direction of travel within
  // +-90 deg (a module would otherwise cross its stop while rolling: draw 171 of seed 2 turned it
  // from 0 to 120.5 deg). Truth: the direction of the reference's own body twist.
  const std::vector<ReferenceFamily> families = {ReferenceFamily::kHeadingChange, ReferenceFamily::kSCurve};
  int limited = 0;
  for (const std::uint64_t seed : {1u, 2u}) {
    for (int index = 0; index < 120; ++index) {
      const Draw draw = draw_case(seed, index, families);
      if (draw.vehicle.steering_limit >= kPi) continue;
      ++limited;
      for (const auto& row : draw.reference.rows) {
        if (std::hypot(row[4], row[5]) < 1e-3) continue;
        // At the stop itself is allowed (a crab at 90 deg), to the generator's 0.5 deg.
        ASSERT_LE(std::abs(std::atan2(row[5], row[4])), kPi / 2 + 0.5 * kDegree)
            << "seed " << seed << " draw " << index << " (" << draw.reference.summary << ") at t = " << row[0];
      }
    }
  }
  EXPECT_GT(limited, 50);
  const Draw known = draw_case(2, 171, {ReferenceFamily::kHeadingChange});  // its family when there were 11
  ASSERT_EQ(known.family, ReferenceFamily::kHeadingChange);
  ASSERT_LT(known.vehicle.steering_limit, kPi);
  double widest = 0.0;
  for (const auto& row : known.reference.rows) {
    if (std::hypot(row[4], row[5]) >= 1e-3) widest = std::max(widest, std::abs(std::atan2(row[5], row[4])));
  }
  EXPECT_LE(widest, kPi / 2);
}

TEST(Envelope, EveryFamilyWritesAScenarioTheLoaderAccepts) {
  const std::string dir = scratch_dir();
  const EnvelopeOptions options = shipped_options(dir);
  for (const ReferenceFamily family : all_reference_families()) {
    for (int index = 0; index < 2; ++index) {
      SCOPED_TRACE(std::string(to_string(family)) + " draw " + std::to_string(index));
      const Draw d = draw_case(5, index, {family});
      const std::string draw_dir = dir + "/" + to_string(family) + "_" + std::to_string(index);
      const std::string file = write_draw(d, draw_dir, options);
      EXPECT_EQ(fs::exists(draw_dir + "/reference.csv"), d.reference.type == "csv");
      try {
        const ScenarioConfig s = load_scenario_config_file(file);
        EXPECT_EQ(s.vehicle.layout.size(), d.vehicle.modules());
        EXPECT_EQ(s.vehicle.mass, d.vehicle.mass);
        EXPECT_EQ(s.simulator.control_period, d.conditions.control_period);
        EXPECT_EQ(s.simulator.measurement_delay_steps, d.conditions.measurement_delay_steps);
        EXPECT_EQ(s.duration, d.duration);
        EXPECT_NEAR(s.reference->duration(), d.reference.duration, 1e-9);
        ASSERT_EQ(s.controllers.size(), 2u);
        EXPECT_EQ(s.controllers[0].config.kind, ControllerKind::kWearMpc);
        EXPECT_EQ(s.controllers[0].config.mpc.solve_budget, d.conditions.solve_budget);
        EXPECT_EQ(s.controllers[1].config.kind, ControllerKind::kKinematicBaseline);
        EXPECT_EQ(s.controllers[1].config.period(), d.conditions.control_period);
        // The written reference starts where the draw's does: a built-in one at the origin.
        EXPECT_NEAR(s.reference->sample(0.0).pose_world.head<2>().norm(), 0.0, 1e-9);
      } catch (const ConfigError& error) {
        ADD_FAILURE() << error.what();
      }
    }
  }
  fs::remove_all(dir);
}

TEST(Envelope, SampledReferencesFollowTheirOwnTwist) {
  // The CSV's twist columns are the rates of its poses: integrating vx, vy, r in the body frame
  // over the rows lands where the poses say.
  for (const ReferenceFamily family : {ReferenceFamily::kLaneChange, ReferenceFamily::kSCurve,
                                       ReferenceFamily::kHeadingChange, ReferenceFamily::kStopAndGo,
                                       ReferenceFamily::kTurnThenGo}) {
    SCOPED_TRACE(to_string(family));
    const Draw d = draw_case(11, 0, {family});
    const auto& rows = d.reference.rows;
    ASSERT_GT(rows.size(), 100u);
    double x = rows[0][1], y = rows[0][2], psi = rows[0][3];
    for (std::size_t k = 1; k < rows.size(); ++k) {
      const double h = rows[k][0] - rows[k - 1][0];
      const auto& a = rows[k - 1];
      const auto& b = rows[k];
      const double psi_mid = psi + 0.25 * h * (a[6] + b[6]);
      const double vx = 0.5 * (a[4] + b[4]), vy = 0.5 * (a[5] + b[5]);
      x += h * (vx * std::cos(psi_mid) - vy * std::sin(psi_mid));
      y += h * (vx * std::sin(psi_mid) + vy * std::cos(psi_mid));
      psi += 0.5 * h * (a[6] + b[6]);
    }
    EXPECT_NEAR(x, rows.back()[1], 0.02);
    EXPECT_NEAR(y, rows.back()[2], 0.02);
    EXPECT_NEAR(psi, rows.back()[3], 1e-3);
  }
}

TEST(Envelope, OptionsRejectEachBadFieldNamingItAndItsValue) {
  EnvelopeOptions good;
  EXPECT_EQ(error_of(good), "");
  EnvelopeOptions o = good;
  o.draws = 0;
  EXPECT_NE(error_of(o).find("EnvelopeOptions.draws = 0"), std::string::npos) << error_of(o);
  o = good;
  o.draws = -3;
  EXPECT_NE(error_of(o).find("EnvelopeOptions.draws = -3"), std::string::npos) << error_of(o);
  o = good;
  o.jobs = 0;
  EXPECT_NE(error_of(o).find("EnvelopeOptions.jobs = 0"), std::string::npos) << error_of(o);
  o = good;
  o.families = {"line", "zigzag"};
  EXPECT_NE(error_of(o).find("EnvelopeOptions.families = 'zigzag'"), std::string::npos) << error_of(o);
  o = good;
  o.families = {""};
  EXPECT_NE(error_of(o).find("EnvelopeOptions.families = ''"), std::string::npos) << error_of(o);
  o = good;
  o.work_clock = -1.0;
  EXPECT_NE(error_of(o).find("EnvelopeOptions.work_clock = -1"), std::string::npos) << error_of(o);
  o = good;
  o.work_clock_evaluation = std::nan("");
  EXPECT_NE(error_of(o).find("EnvelopeOptions.work_clock_evaluation = nan"), std::string::npos) << error_of(o);
  o = good;
  o.out_dir = "";
  EXPECT_NE(error_of(o).find("EnvelopeOptions.out_dir"), std::string::npos) << error_of(o);
  o = good;
  o.controller_file = "";
  EXPECT_NE(error_of(o).find("EnvelopeOptions.controller_file"), std::string::npos) << error_of(o);
  o = good;
  o.baseline_file = "";
  EXPECT_NE(error_of(o).find("EnvelopeOptions.baseline_file"), std::string::npos) << error_of(o);
}

TEST(Envelope, FamilyNamesRoundTrip) {
  for (const ReferenceFamily family : all_reference_families()) {
    ASSERT_TRUE(reference_family_named(to_string(family)).has_value());
    EXPECT_EQ(*reference_family_named(to_string(family)), family);
  }
  EXPECT_FALSE(reference_family_named("zigzag").has_value());
  EXPECT_EQ(all_reference_families().size(), 12u);
}

EnvelopeRun run_with(double wear, double rmse, double heading, double effort) {
  EnvelopeRun run;
  run.ran = run.completed = true;
  run.metrics.wear_total = wear;
  run.metrics.tracking_rmse_m = rmse;
  run.metrics.heading_rmse_rad = heading;
  run.metrics.steering_effort = effort;
  return run;
}

TEST(Envelope, GoalsHoldAtTheirBoundsAndFailJustPast) {
  const EnvelopeRun baseline = run_with(10.0, 0.1, 0.02, 2.0);
  // Bounds: wear 10; RMSE max(0.11, 0.12) = 0.12; heading max(0.022, 0.02 + 0.5 deg);
  // effort max(3.0, 2.5) = 3.0.
  const double heading_bound = 0.02 + 0.5 * kDegree;
  const EnvelopeGoals at_bounds = evaluate_goals(run_with(10.0, 0.12, heading_bound, 3.0), baseline);
  EXPECT_TRUE(at_bounds.all());
  EXPECT_FALSE(at_bounds.gross);
  EXPECT_DOUBLE_EQ(at_bounds.wear_ratio, 1.0);
  EXPECT_DOUBLE_EQ(at_bounds.steering_effort_ratio, 1.5);
  EXPECT_NEAR(at_bounds.rmse_excess_m, 0.02, 1e-12);

  EXPECT_FALSE(evaluate_goals(run_with(10.01, 0.1, 0.02, 2.0), baseline).wear);
  EXPECT_FALSE(evaluate_goals(run_with(5.0, 0.1201, 0.02, 2.0), baseline).position);
  EXPECT_FALSE(evaluate_goals(run_with(5.0, 0.1, heading_bound + 1e-6, 2.0), baseline).heading);
  EXPECT_FALSE(evaluate_goals(run_with(5.0, 0.1, 0.02, 3.01), baseline).steering_effort);

  EnvelopeRun missed = run_with(5.0, 0.1, 0.02, 2.0);
  missed.metrics.deadline_misses = 1;
  EXPECT_FALSE(evaluate_goals(missed, baseline).deadlines);
  EXPECT_FALSE(evaluate_goals(missed, baseline).all());
  EnvelopeRun stopped = run_with(5.0, 0.1, 0.02, 2.0);
  stopped.safe_stops = 1;
  EXPECT_FALSE(evaluate_goals(stopped, baseline).no_safe_stop);
  EXPECT_FALSE(evaluate_goals(stopped, baseline).all());
}

TEST(Envelope, GrossDrawsAreTwiceTheWearOrFiveCentimetresWorse) {
  const EnvelopeRun baseline = run_with(10.0, 0.1, 0.02, 2.0);
  EXPECT_FALSE(evaluate_goals(run_with(20.0, 0.15, 0.02, 2.0), baseline).gross);
  EXPECT_TRUE(evaluate_goals(run_with(20.01, 0.1, 0.02, 2.0), baseline).gross);
  EXPECT_TRUE(evaluate_goals(run_with(5.0, 0.1501, 0.02, 2.0), baseline).gross);
}

TEST(Envelope, ARunThatDidNotCompleteMeetsNoGoal) {
  const EnvelopeRun baseline = run_with(10.0, 0.1, 0.02, 2.0);
  EnvelopeRun diverged = run_with(1.0, 0.05, 0.01, 1.0);
  diverged.completed = false;
  EXPECT_FALSE(evaluate_goals(diverged, baseline).all());
  const EnvelopeGoals none = evaluate_goals(EnvelopeRun{}, baseline);
  EXPECT_FALSE(none.ran);
  EXPECT_FALSE(none.all());
  EXPECT_TRUE(std::isnan(none.wear_ratio));
}

TEST(Envelope, CountsSafeStopPeriods) {
  std::vector<StepRecord> log(5);
  for (StepRecord& r : log) r.source = CommandSource::kOptimizer;
  log[1].source = log[3].source = CommandSource::kSafeStop;
  EXPECT_EQ(count_safe_stops(log), 2);
}

TEST(Envelope, RunsOneShortDrawEndToEndFromItsWrittenFiles) {
  const std::string dir = scratch_dir();
  const EnvelopeOptions options = shipped_options(dir);
  // A small vehicle, to keep the test short; the search is deterministic.
  Draw d = draw_case(1, 0, {ReferenceFamily::kLaneChange});
  for (int index = 1; d.vehicle.modules() > 4 && index < 50; ++index) {
    d = draw_case(1, index, {ReferenceFamily::kLaneChange});
  }
  d.duration = 0.5;
  const DrawResult r = run_draw(d, dir + "/draws/0", options);
  ASSERT_EQ(r.error, "");
  EXPECT_TRUE(r.wear_mpc.ran);
  EXPECT_TRUE(r.baseline.ran);
  const int steps = static_cast<int>(std::ceil(0.5 / d.conditions.control_period - 1e-9));
  EXPECT_EQ(r.wear_mpc.metrics.steps, steps);
  EXPECT_EQ(r.baseline.metrics.steps, steps);
  EXPECT_TRUE(fs::exists(r.scenario_file));
  EXPECT_EQ(load_scenario_config_file(r.scenario_file).duration, 0.5);

  // On the work clock the same draw runs the same, bit for bit.
  const DrawResult again = run_draw(d, dir + "/draws/1", options);
  EXPECT_EQ(again.wear_mpc.metrics.wear_total, r.wear_mpc.metrics.wear_total);
  EXPECT_EQ(again.baseline.metrics.tracking_rmse_m, r.baseline.metrics.tracking_rmse_m);

  EnvelopeResult result;
  result.options = options;
  result.options.draws = 1;
  result.draws.push_back(r);
  const nlohmann::json j = nlohmann::json::parse(envelope_json(result));
  ASSERT_EQ(j["per_draw"].size(), 1u);
  EXPECT_EQ(j["per_draw"][0]["scenario_file"], r.scenario_file);
  EXPECT_EQ(j["per_draw"][0]["family"], "lane_change");
  EXPECT_TRUE(j["per_draw"][0]["wear_mpc"].contains("steering_effort_rad2_s"));
  EXPECT_TRUE(j["per_draw"][0]["kinematic_baseline"].contains("safe_stops"));
  fs::remove_all(dir);
}

TEST(Envelope, ADrawThatFailsIsReportedWithItsScenarioFileNotDropped) {
  const std::string dir = scratch_dir();
  EnvelopeOptions options = shipped_options(dir);
  options.controller_file = dir + "/missing_controller.yaml";
  const DrawResult failed = run_draw(draw_case(1, 0, all_reference_families()), dir + "/draws/0", options);
  EXPECT_NE(failed.error, "");
  EXPECT_FALSE(failed.goals.all());
  EXPECT_EQ(failed.scenario_file, dir + "/draws/0/scenario.yaml");

  EnvelopeResult result;
  result.options = shipped_options(dir);
  result.options.draws = 1;
  result.draws.push_back(failed);
  result.failed = 1;
  const std::string report = envelope_report(result);
  EXPECT_NE(report.find(failed.scenario_file), std::string::npos) << report;
  EXPECT_NE(report.find("goals met: 0 of 1"), std::string::npos) << report;
  const nlohmann::json j = nlohmann::json::parse(envelope_json(result));
  EXPECT_EQ(j["per_draw"].size(), 1u);
  EXPECT_FALSE(j["per_draw"][0]["error"].is_null());
  EXPECT_FALSE(j["per_draw"][0]["goals"]["all"].get<bool>());
  EXPECT_EQ(j["rate"].get<double>(), 0.0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace swerve
