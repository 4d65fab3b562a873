// The wear-versus-tracking sweep: the kinematic baseline once, then the wear-aware controller of a
// scenario at each of a list of wear weights or tracking tolerances, all on the same plant, seed
// and reference. `swerve-mpc sweep` and the Python module both run it.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "swerve/app/scenario_runner.hpp"

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
};

struct SweepResult {
  ScenarioConfig baseline_scenario;  // the scenario as the baselines ran it (for reports)
  ControllerRun baseline;
  std::vector<SweepRun> points;  // in the order given
  // The scenario's practical_baseline, run once after the points, when the scenario lists one.
  std::optional<ControllerRun> practical;
};

// Called after the baseline (point == nullptr) and after each point.
using SweepCallback = std::function<void(const SweepPoint* point, const ControllerRun& run)>;

// Needs the scenario's controllers `kinematic_baseline` and `wear_mpc` (OverrideError otherwise),
// at least one point, and each point with exactly one of wear_weight >= 0 and a valid tolerance
// (ConfigError naming the point and value). `overrides` apply to every run (seed, backend).
SweepResult run_sweep(const ScenarioConfig& scenario, const RunOverrides& overrides,
                      const std::vector<SweepPoint>& points, const SweepCallback& after_each = {});

}  // namespace swerve
