// measure_real_time: the wear-aware controller's step times on a target's budget, per scenario.
#include <algorithm>
#include <optional>
#include <vector>

#include "swerve/app/tuning.hpp"
#include "swerve/sim/metrics.hpp"
#include "tuning_runs.hpp"

namespace swerve {

bool RealTimeRow::passes() const { return completed && deadline_misses == 0 && step_p99_ms <= budget_ms; }

std::vector<RealTimeRow> measure_real_time(const ControllerConfig& controller, const TargetConfig& target,
                                           const std::vector<ScenarioConfig>& scenarios, const Clock* clock) {
  target.validate();
  require_wear_mpc(controller, "bench-targets");
  std::vector<RealTimeRow> rows;
  for (const ScenarioConfig& scenario : scenarios) {
    ScenarioController entry{"wear_mpc", "", controller};
    // At the file's own period where the target allows it; else at the target's, the prediction
    // step in the same ratio to it as in the file.
    const std::optional<double> own_budget = target.budget_at(controller.mpc.period());
    const double period = own_budget ? controller.mpc.period() : target.control_period;
    const double budget = own_budget ? *own_budget : target.solve_budget;
    const bool longer_step = controller.mpc.dt > controller.mpc.period();
    entry.config.set_sampling(controller.mpc.horizon,
                              longer_step ? controller.mpc.dt * (period / controller.mpc.period()) : period);
    entry.config.mpc.control_period = period;
    entry.config.mpc.solve_budget = budget / target.cpu_slowdown;
    const CountedRun counted = run_counting_recurring_misses(at_period(scenario, period), entry, clock);
    const ControllerRun& run = counted.run;
    std::vector<double> steps_ms, proposals;
    for (const StepRecord& record : run.log) {
      if (record.step_time_s >= 0.0) steps_ms.push_back(1e3 * record.step_time_s * target.cpu_slowdown);
      if (record.solve_time_s >= 0.0) proposals.push_back(std::max(0, record.solve_iterations));
    }
    RealTimeRow row;
    row.scenario = scenario.name;
    row.period_ms = 1e3 * period;
    row.budget_ms = 1e3 * budget;
    row.step_p50_ms = percentile(steps_ms, 50.0);
    row.step_p99_ms = percentile(steps_ms, 99.0);
    row.step_max_ms = steps_ms.empty() ? 0.0 : *std::max_element(steps_ms.begin(), steps_ms.end());
    row.proposals_median = percentile(proposals, 50.0);
    row.deadline_misses = counted.misses;
    row.unconfirmed_misses = counted.unconfirmed;
    row.fallbacks = run.metrics.fallbacks;
    row.completed = run.completed;
    rows.push_back(row);
  }
  return rows;
}

}  // namespace swerve
