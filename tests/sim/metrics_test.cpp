// Run metrics on hand-made logs whose answers are known in closed form.
#include "swerve/sim/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace swerve {
namespace {

StepRecord record(double t, double error_x, double error_psi, double solve_s, CommandSource source) {
  StepRecord r;
  r.t = t;
  r.reference_pose_world << t, 0.0, 0.5;
  r.pose_world << t + error_x, 0.0, 0.5 + error_psi;
  r.solve_time_s = solve_s;
  r.source = source;
  r.commands.resize(2);
  r.commands[0].steering_rate = 1.0;
  r.commands[1].steering_rate = -2.0;
  return r;
}

TEST(Metrics, TrackingErrorRmseAndMaxOfAKnownSignal) {
  // Errors 0.3 and -0.4 alternate: RMSE = sqrt((0.09 + 0.16) / 2), max 0.4.
  std::vector<StepRecord> log;
  for (int k = 0; k < 10; ++k) {
    log.push_back(record(0.1 * k, k % 2 == 0 ? 0.3 : -0.4, k % 2 == 0 ? 0.1 : -0.2, 0.001, CommandSource::kOptimizer));
  }
  const RunMetrics m = compute_metrics(log, {1.0, 3.0}, 5.0, 0.1, 0.02);
  EXPECT_NEAR(m.tracking_rmse_m, std::sqrt(0.125), 1e-12);
  EXPECT_NEAR(m.tracking_max_m, 0.4, 1e-12);
  EXPECT_NEAR(m.heading_rmse_rad, std::sqrt((0.01 + 0.04) / 2.0), 1e-12);
  EXPECT_NEAR(m.heading_max_rad, 0.2, 1e-12);
  EXPECT_EQ(m.steps, 10);
}

TEST(Metrics, HeadingErrorIsWrappedAcrossPi) {
  StepRecord r = record(0.0, 0.0, 0.0, -1.0, CommandSource::kOptimizer);
  r.reference_pose_world.z() = kPi - 0.05;
  r.pose_world.z() = -kPi + 0.05;  // 0.1 rad away, not 2 pi - 0.1
  EXPECT_NEAR(std::abs(r.heading_error()), 0.1, 1e-12);
}

TEST(Metrics, WearSumImbalanceEffortAndEnergy) {
  std::vector<StepRecord> log = {record(0.0, 0.0, 0.0, 0.001, CommandSource::kOptimizer),
                                 record(0.1, 0.0, 0.0, 0.001, CommandSource::kOptimizer)};
  const RunMetrics m = compute_metrics(log, {1.0, 3.0}, 7.5, 0.1, 0.02);
  EXPECT_DOUBLE_EQ(m.wear_total, 4.0);
  EXPECT_DOUBLE_EQ(m.wear_imbalance, 1.5);  // max 3 over mean 2
  EXPECT_DOUBLE_EQ(m.frictional_energy_J, 7.5);
  EXPECT_NEAR(m.steering_effort, 2 * 0.1 * (1.0 + 4.0), 1e-12);  // two periods of (1^2 + 2^2) dt
}

TEST(Metrics, SolveTimesPercentilesDeadlineMissesLateSolvesAndFallbacks) {
  std::vector<StepRecord> log;
  for (int k = 1; k <= 100; ++k) {
    // 1..100 ms; the last five over a 95 ms budget; every tenth from a fallback; one without a solve.
    const CommandSource source = k % 10 == 0 ? CommandSource::kBaseline : CommandSource::kOptimizer;
    log.push_back(record(0.01 * k, 0.0, 0.0, 1e-3 * k, source));
    if (k > 97) log.back().solve_late_s = 1e-3 * (k - 95);  // three of the five misses ran late in the solver
  }
  log.push_back(record(2.0, 0.0, 0.0, -1.0, CommandSource::kSafeStop));
  const RunMetrics m = compute_metrics(log, {0.0, 0.0}, 0.0, 0.01, 0.095);
  EXPECT_NEAR(m.solve_time_p50_ms, 50.0, 1e-9);
  EXPECT_NEAR(m.solve_time_p99_ms, 99.0, 1e-9);
  EXPECT_NEAR(m.solve_time_max_ms, 100.0, 1e-9);
  EXPECT_NEAR(m.solve_time_mean_ms, 50.5, 1e-9);
  EXPECT_EQ(m.deadline_misses, 5);
  EXPECT_EQ(m.late_solves, 3);
  EXPECT_EQ(m.fallbacks, 11);
  EXPECT_DOUBLE_EQ(m.wear_imbalance, 0.0);  // no wear: no imbalance rather than 0/0
}

TEST(Metrics, TheGripUsedSettlesWhenItStaysWithinTenPercentOfTheFloorsUntilTheFloorChanges) {
  // A floor of scale 1, then 0.75 under part of the vehicle at 1 s, all of it at 2 s, dry again at
  // 5 s. The grip used comes within 10 % at 2.5 s, strays at 3 s, and stays within from 3.1 s. A
  // second, deeper patch from 5.5 s is not the first change.
  std::vector<StepRecord> log;
  for (int k = 0; k < 70; ++k) {
    StepRecord r = record(0.1 * k, 0.0, 0.0, 0.001, CommandSource::kOptimizer);
    r.friction_scale = k < 10 ? 1.0 : k < 20 ? 0.75 + 0.25 * (20 - k) / 11.0 : k < 50 ? 0.75 : k < 55 ? 1.0 : 0.3;
    r.friction_scale_used = k < 25 ? 1.0 : k == 30 ? 0.9 : k < 35 ? 0.78 : 0.76;
    if (k == 25) r.friction_scale_used = 0.82;
    log.push_back(r);
  }
  const RunMetrics m = compute_metrics(log, {}, 0.0, 0.1, 0.05);
  EXPECT_NEAR(m.friction_change_s, 1.0, 1e-12);
  EXPECT_NEAR(m.friction_change_complete_s, 2.0, 1e-12);
  EXPECT_NEAR(m.friction_settle_after_change_s, 2.1, 1e-12);    // from 3.1 s (3.0 s was 20 % off)
  EXPECT_NEAR(m.friction_settle_after_complete_s, 1.1, 1e-12);
  EXPECT_NEAR(m.friction_error_after_settle_max_pct, 100.0 * (0.78 / 0.75 - 1.0), 1e-9);
  // A run on one floor has no change to settle on.
  const RunMetrics dry = compute_metrics(std::vector<StepRecord>(3, record(0.0, 0.0, 0.0, 0.001, CommandSource::kOptimizer)),
                                         {}, 0.0, 0.1, 0.05);
  EXPECT_LT(dry.friction_change_s, 0.0);
  EXPECT_LT(dry.friction_settle_after_change_s, 0.0);
}

TEST(Metrics, PercentileIsNearestRank) {
  EXPECT_DOUBLE_EQ(percentile({}, 99.0), 0.0);
  EXPECT_DOUBLE_EQ(percentile({3.0, 1.0, 2.0}, 50.0), 2.0);
  EXPECT_DOUBLE_EQ(percentile({3.0, 1.0, 2.0}, 100.0), 3.0);
  EXPECT_DOUBLE_EQ(percentile({3.0, 1.0, 2.0}, 0.0), 1.0);
}

TEST(Metrics, AFaultsDetectionDelayTheTrackingAfterItAndFalseAlarmsFromTheMasks) {
  // The plant's module 1 fails at step 3; the controller knows of it from step 5 (2 cycles) and
  // wrongly takes module 0 as faulty at step 8: one false alarm. Errors 0.1 before step 5, 0.3 from
  // it on: the RMSE after detection is 0.3. Step 6 sent a safe stop.
  std::vector<StepRecord> log;
  for (int k = 0; k < 10; ++k) {
    StepRecord r = record(0.1 * k, k < 5 ? 0.1 : 0.3, 0.0, 0.001, k == 6 ? CommandSource::kSafeStop : CommandSource::kOptimizer);
    r.plant_faults = k >= 3 ? 0b10u : 0u;
    r.known_faults = (k >= 5 ? 0b10u : 0u) | (k >= 8 ? 0b01u : 0u);
    log.push_back(r);
  }
  const RunMetrics m = compute_metrics(log, {1.0, 1.0}, 1.0, 0.1, 0.02);
  EXPECT_NEAR(m.fault_onset_s, 0.3, 1e-12);
  EXPECT_EQ(m.fault_detection_cycles, 2);
  EXPECT_NEAR(m.tracking_rmse_after_fault_known_m, 0.3, 1e-12);
  EXPECT_EQ(m.false_fault_alarms, 1);
  EXPECT_EQ(m.safe_stops, 1);
}

TEST(Metrics, WithoutFaultsTheFaultFieldsSayNone) {
  const std::vector<StepRecord> log = {record(0.0, 0.0, 0.0, 0.001, CommandSource::kOptimizer)};
  const RunMetrics m = compute_metrics(log, {1.0}, 1.0, 0.1, 0.02);
  EXPECT_EQ(m.fault_onset_s, -1.0);
  EXPECT_EQ(m.fault_detection_cycles, -1);
  EXPECT_EQ(m.tracking_rmse_after_fault_known_m, -1.0);
  EXPECT_EQ(m.false_fault_alarms, 0);
}

}  // namespace
}  // namespace swerve
