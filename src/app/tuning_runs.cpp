#include "tuning_runs.hpp"

#include <algorithm>
#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve {

void require_wear_mpc(const ControllerConfig& controller, const char* command) {
  if (controller.kind != ControllerKind::kWearMpc) {
    throw ConfigError(std::string(command) + ": controller '" + controller.name + "' is a " + to_string(controller.kind) +
                      "; it needs the wear_mpc controller");
  }
}

ScenarioConfig at_period(const ScenarioConfig& scenario, double period) {
  ScenarioConfig copy = scenario;
  copy.simulator.control_period = period;
  return copy;
}

CountedRun run_counting_recurring_misses(const ScenarioConfig& scenario, const ScenarioController& entry,
                                         const Clock* clock) {
  CountedRun counted{run_controller(scenario, entry, {}, 0, clock)};
  counted.misses = counted.run.metrics.deadline_misses;
  if (counted.misses > 0) {
    const ControllerRun again = run_controller(scenario, entry, {}, 0, clock);
    const int recurring = std::min(counted.misses, again.metrics.deadline_misses);
    counted.unconfirmed = counted.misses - recurring;
    counted.misses = recurring;
  }
  return counted;
}

}  // namespace swerve
