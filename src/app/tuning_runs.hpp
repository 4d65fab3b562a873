// What the tuner and the real-time report share (internal to the app layer): the check that a
// controller is the wear-aware one, a scenario at another control period, and one run with the
// deadline misses that count.
#pragma once

#include "swerve/app/controller_config.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/scenario_runner.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

// Tuning and the real-time report are about the wear-aware controller: ConfigError naming
// `command` and the controller otherwise.
void require_wear_mpc(const ControllerConfig& controller, const char* command);

// The scenario at a control period.
ScenarioConfig at_period(const ScenarioConfig& scenario, double period);

// One run, and the misses that count: a run with a miss is run again (same seed), and the fewer of
// the two runs' miss counts count (a count, not matched step by step; the first run is kept). A
// scheduling stall of the machine misses at random and seldom in both runs; a controller too slow
// for its budget misses in both. The tuner and the real-time report count them alike.
struct CountedRun {
  ControllerRun run;
  int misses = 0;       // those that recurred
  int unconfirmed = 0;  // the first run's others
};
CountedRun run_counting_recurring_misses(const ScenarioConfig& scenario, const ScenarioController& entry,
                                         const Clock* clock);

}  // namespace swerve
