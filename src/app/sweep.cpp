// The wear-versus-tracking sweep (see sweep.hpp).
#include "swerve/app/sweep.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <string>

#include "swerve/app/run_report.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/core/text_file.hpp"

namespace swerve {
namespace {

void check_point(const SweepPoint& point, std::size_t index) {
  const std::string where = "sweep point[" + std::to_string(index) + "]";
  if (point.wear_weight.has_value() == point.tolerance.has_value()) {
    throw ConfigError(where + ": give exactly one of a wear weight and a tracking tolerance");
  }
  if (point.wear_weight && !(std::isfinite(*point.wear_weight) && *point.wear_weight >= 0.0)) {
    throw_invalid_field(where, "wear_weight", *point.wear_weight, "must be finite and >= 0");
  }
  if (point.tolerance) {
    if (!point.tolerance->enabled()) {
      throw_invalid_field(where, "tolerance.position", point.tolerance->position,
                          "the position or the heading tolerance must be > 0");
    }
    try {
      point.tolerance->validate();
    } catch (const ConfigError& error) {
      throw ConfigError(where + ": " + error.what());
    }
  }
}

}  // namespace

SweepResult run_sweep(const ScenarioConfig& scenario, const RunOverrides& overrides,
                      const std::vector<SweepPoint>& points, const SweepCallback& after_each, const Shard& shard,
                      const WorkClockRates& work_clock) {
  shard.validate();
  if (points.empty()) throw ConfigError("sweep: no points: give at least one wear weight or tolerance");
  for (std::size_t i = 0; i < points.size(); ++i) check_point(points[i], i);

  // Every run is set up before the first one starts, so a bad override costs no simulation.
  RunOverrides baseline_only = overrides;
  baseline_only.controllers = {"kinematic_baseline"};
  bool has_practical = false;
  for (const ScenarioController& c : scenario.controllers) has_practical = has_practical || c.name == "practical_baseline";
  if (has_practical) baseline_only.controllers.push_back("practical_baseline");
  std::vector<ScenarioConfig> point_scenarios;
  for (const SweepPoint& point : points) {
    RunOverrides o = overrides;
    o.controllers = {"wear_mpc"};
    o.wear_weight = point.wear_weight;
    o.tracking_tolerance = point.tolerance;
    point_scenarios.push_back(apply_overrides(scenario, o));
  }
  SweepResult result{apply_overrides(scenario, baseline_only), {}, {}, std::nullopt};

  // Each run on a clock of its own from zero, so no run depends on the one before it.
  const auto run_on_clock = [&](const ScenarioConfig& s, const ScenarioController& c) {
    if (work_clock.per_read_s <= 0.0) return run_controller(s, c);
    const WorkClock clock(work_clock.per_read_s, work_clock.per_module_evaluation_s);
    return run_controller(s, c, {}, 0, &clock);
  };
  const auto run_named = [&](const char* name) {
    for (const ScenarioController& c : result.baseline_scenario.controllers) {
      if (c.name == name) return run_on_clock(result.baseline_scenario, c);
    }
    throw ConfigError(std::string("sweep: no controller ") + name);  // not reached: apply_overrides kept it
  };
  result.baseline = run_named("kinematic_baseline");
  if (after_each) after_each(nullptr, result.baseline);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!shard.owns(static_cast<int>(i))) continue;
    const ScenarioConfig& s = point_scenarios[i];
    result.points.push_back({points[i], run_on_clock(s, s.controllers.front()), static_cast<int>(i)});
    if (after_each) after_each(&points[i], result.points.back().run);
  }
  if (has_practical && shard.index == 0) result.practical = run_named("practical_baseline");
  return result;
}

std::string sweep_table_header() {
  char line[160];
  std::snprintf(line, sizeof line, "%-22s %12s %14s %14s %10s %12s\n", "point", "rmse [m]", "wear total",
                "vs base [%]", "p99 [ms]", "lambda used");
  return line;
}

std::string sweep_table_row(const SweepPoint* point, const ControllerRun& r, const RunMetrics& baseline) {
  char line[256];
  if (point == nullptr) {
    std::snprintf(line, sizeof line, "%-22s %12.4f %14.2f %14s %10s %12s\n", "baseline", r.metrics.tracking_rmse_m,
                  r.metrics.wear_total, "-", "-", "-");
    return line;
  }
  char label[64];
  if (point->tolerance) {
    std::snprintf(label, sizeof label, "tol %g m, %g rad", point->tolerance->position, point->tolerance->heading);
  } else {
    std::snprintf(label, sizeof label, "lambda %g", *point->wear_weight);
  }
  // lambda used: the weight the cost had after the controller's reference-mass scaling
  // (weights.wear_reference_mass), which the requested one is scaled by.
  std::snprintf(line, sizeof line, "%-22s %12.4f %14.2f %14.2f %10.2f %12.4g%s\n", label, r.metrics.tracking_rmse_m,
                r.metrics.wear_total, -wear_reduction_pct(r.metrics, baseline), r.metrics.solve_time_p99_ms,
                r.effective_wear_weight, r.completed ? "" : "  (plant diverged)");
  return line;
}

std::string sweep_practical_row(const ControllerRun& practical, const RunMetrics& baseline) {
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %12.4f %14.2f %14.2f %10s %12s   (late by %.2f s)\n", "practical_baseline",
                practical.metrics.tracking_rmse_m, practical.metrics.wear_total,
                -wear_reduction_pct(practical.metrics, baseline), "-", "-", practical.metrics.reference_delay_s);
  return line;
}

std::string sweep_json(const std::string& scenario_name, const ControllerRun& baseline,
                       const std::vector<SweepRun>& points, const std::optional<ControllerRun>& practical) {
  nlohmann::json list = nlohmann::json::array();
  for (const SweepRun& point : points) {
    const ControllerRun& r = point.run;
    nlohmann::json p = {{"wear_weight", r.wear_weight},
                        {"effective_wear_weight", r.effective_wear_weight},
                        {"tracking_rmse_m", r.metrics.tracking_rmse_m},
                        {"wear_total", r.metrics.wear_total},
                        {"wear_reduction_pct", wear_reduction_pct(r.metrics, baseline.metrics)},
                        {"wear_reduction_vs_practical_pct",
                         practical ? nlohmann::json(wear_reduction_pct(r.metrics, practical->metrics)) : nlohmann::json()},
                        {"solve_time_p99_ms", r.metrics.solve_time_p99_ms},
                        {"completed", r.completed}};
    if (point.point.tolerance) {
      p["tolerance_position_m"] = point.point.tolerance->position;
      p["tolerance_heading_rad"] = point.point.tolerance->heading;
    }
    list.push_back(p);
  }
  nlohmann::json j = {
      {"scenario", scenario_name},
      {"swept", !points.empty() && points.front().point.tolerance ? "tracking_tolerance" : "wear_weight"},
      {"points", list},
      {"baseline", {{"tracking_rmse_m", baseline.metrics.tracking_rmse_m}, {"wear_total", baseline.metrics.wear_total}}}};
  if (practical) {
    j["practical_baseline"] = {{"tracking_rmse_m", practical->metrics.tracking_rmse_m},
                               {"wear_total", practical->metrics.wear_total},
                               {"reference_delay_s", practical->metrics.reference_delay_s}};
  }
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void write_sweep_json(const std::string& sweep_dir, const std::string& scenario_name, const ControllerRun& baseline,
                      const std::vector<SweepRun>& points, const std::optional<ControllerRun>& practical) {
  config::write_text_file_atomically(sweep_dir + "/sweep.json", sweep_json(scenario_name, baseline, points, practical));
}

}  // namespace swerve
