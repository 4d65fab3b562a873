// The wear-versus-tracking sweep (see sweep.hpp).
#include "swerve/app/sweep.hpp"

#include <cmath>
#include <string>

#include "swerve/core/config_error.hpp"

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
                      const std::vector<SweepPoint>& points, const SweepCallback& after_each) {
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

  const auto run_named = [&](const char* name) {
    for (const ScenarioController& c : result.baseline_scenario.controllers) {
      if (c.name == name) return run_controller(result.baseline_scenario, c);
    }
    throw ConfigError(std::string("sweep: no controller ") + name);  // not reached: apply_overrides kept it
  };
  result.baseline = run_named("kinematic_baseline");
  if (after_each) after_each(nullptr, result.baseline);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ScenarioConfig& s = point_scenarios[i];
    result.points.push_back({points[i], run_controller(s, s.controllers.front())});
    if (after_each) after_each(&points[i], result.points.back().run);
  }
  if (has_practical) result.practical = run_named("practical_baseline");
  return result;
}

}  // namespace swerve
