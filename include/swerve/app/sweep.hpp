// The wear-versus-tracking sweep: the kinematic baseline once, then the wear-aware controller of a
// scenario at each of a list of wear weights or tracking tolerances, all on the same plant, seed
// and reference. `swerve-mpc sweep` and the Python module both run it.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "swerve/app/scenario_runner.hpp"
#include "swerve/app/shard.hpp"
#include "swerve/ocp/work_clock_rates.hpp"

namespace swerve {

// One sweep point: the wear-aware controller with its wear weight (lambda) or its tracking
// tolerance overridden; exactly one of the two is set.
struct SweepPoint {
  std::optional<double> wear_weight;
  std::optional<TrackingTolerance> tolerance;
};

struct SweepRun {
  SweepPoint point;
  ControllerRun run;  // run.wear_weight as configured, run.effective_wear_weight as the cost used it
  int index = 0;      // the point's place in the list given
};

struct SweepResult {
  ScenarioConfig baseline_scenario;  // the scenario as the baselines ran it (for reports)
  ControllerRun baseline;
  std::vector<SweepRun> points;  // in the order given (a shard's: its own points)
  // The scenario's practical_baseline, run once after the points, when the scenario lists one (by
  // shard 0 alone when sharded).
  std::optional<ControllerRun> practical;
};

// Called after the baseline (point == nullptr) and after each point.
using SweepCallback = std::function<void(const SweepPoint* point, const ControllerRun& run)>;

// Needs the scenario's controllers `kinematic_baseline` and `wear_mpc` (OverrideError otherwise),
// at least one point, and each point with exactly one of wear_weight >= 0 and a valid tolerance
// (ConfigError naming the point and value). `overrides` apply to every run (seed, backend). With a
// shard, only the points whose index it owns (the baseline runs in every shard: each prints its
// rows against it). With work_clock.per_read_s > 0 every run is on a work clock of its own from zero
// (deadlines and timings repeatable), else on the wall clock.
SweepResult run_sweep(const ScenarioConfig& scenario, const RunOverrides& overrides,
                      const std::vector<SweepPoint>& points, const SweepCallback& after_each = {},
                      const Shard& shard = Shard{}, const WorkClockRates& work_clock = WorkClockRates{});

// The printed table: its header, one row per run (point == nullptr: the baseline's), and the
// practical baseline's row.
std::string sweep_table_header();
std::string sweep_table_row(const SweepPoint* point, const ControllerRun& run, const RunMetrics& baseline);
std::string sweep_practical_row(const ControllerRun& practical, const RunMetrics& baseline);

// sweep.json's text: the scenario's name, what was swept, each point, the baseline and the
// practical baseline.
std::string sweep_json(const std::string& scenario_name, const ControllerRun& baseline,
                       const std::vector<SweepRun>& points, const std::optional<ControllerRun>& practical);
// <sweep_dir>/sweep.json with that text, written atomically (std::runtime_error naming it).
void write_sweep_json(const std::string& sweep_dir, const std::string& scenario_name, const ControllerRun& baseline,
                      const std::vector<SweepRun>& points, const std::optional<ControllerRun>& practical);

// What every shard of one sweep shares, and merge checks: the scenario's name, every point in
// order, the command line's overrides (seed, backend; as text) and the clock.
struct SweepIdentity {
  std::string scenario;
  std::vector<SweepPoint> points;
  std::string overrides;
  WorkClockRates clock;
};
// A shard's record (<out>/sweep/shard.json) for merge_sweep_shards: its identity and every run's
// metrics losslessly.
void write_sweep_shard(const SweepIdentity& identity, const SweepResult& result, const Shard& shard,
                       const std::string& path);

// The sweep of shards 0..N-1 (their sweep folders, any order), as the unsharded run gives it: the
// baseline (and practical baseline) files copied from shard 0's folder into `out_sweep_dir`, and
// every point in order. Throws ConfigError naming the folder for a missing or foreign shard (another
// identity, or, on a work clock, another baseline run).
struct MergedSweep {
  std::string scenario_name;
  ControllerRun baseline;
  std::vector<SweepRun> points;
  std::optional<ControllerRun> practical;
};
MergedSweep merge_sweep_shards(const std::vector<std::string>& shard_sweep_dirs, const std::string& out_sweep_dir);

}  // namespace swerve
