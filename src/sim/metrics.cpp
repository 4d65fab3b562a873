#include "swerve/sim/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace swerve {

double StepRecord::heading_error() const { return wrap_angle(pose_world.z() - reference_pose_world.z()); }

double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(std::clamp(q, 0.0, 100.0) / 100.0 * static_cast<double>(values.size()));
  const auto index = static_cast<std::size_t>(std::max(1.0, rank)) - 1;
  return values[std::min(index, values.size() - 1)];
}

namespace {

// RunMetrics' fault fields from the log's fault masks.
void add_fault_metrics(const std::vector<StepRecord>& log, RunMetrics* m) {
  std::uint32_t false_alarms = 0;
  int onset = -1, known = -1;
  for (std::size_t k = 0; k < log.size(); ++k) {
    const StepRecord& record = log[k];
    false_alarms |= record.known_faults & ~record.plant_faults;
    if (onset < 0 && record.plant_faults != 0) onset = static_cast<int>(k);
    if (onset >= 0 && known < 0 && (record.known_faults & record.plant_faults) != 0) known = static_cast<int>(k);
  }
  for (; false_alarms != 0; false_alarms &= false_alarms - 1) ++m->false_fault_alarms;
  if (onset < 0) return;
  m->fault_onset_s = log[static_cast<std::size_t>(onset)].t;
  if (known < 0) return;
  m->fault_detection_cycles = known - onset;
  double position_sq = 0.0;
  for (std::size_t k = static_cast<std::size_t>(known); k < log.size(); ++k) {
    position_sq += log[k].position_error() * log[k].position_error();
  }
  m->tracking_rmse_after_fault_known_m = std::sqrt(position_sq / static_cast<double>(log.size() - static_cast<std::size_t>(known)));
}

// RunMetrics' friction fields from the first change of the floor's grip in the log (the first
// excursion from the start's grip, until it is back): the vehicle first touches it at k0, stands
// wholly on it at k1 (where the excursion departs furthest), and it holds until k2; the grip used
// has settled from the first period after which it stays within 10 % of the floor's until k2.
void add_friction_metrics(const std::vector<StepRecord>& log, RunMetrics* m) {
  constexpr double kSame = 1e-9;
  constexpr double kSettled = 0.10;
  if (log.empty()) return;
  const double start = log.front().friction_scale;
  std::size_t k0 = 0;
  while (k0 < log.size() && std::abs(log[k0].friction_scale - start) <= kSame) ++k0;
  if (k0 == log.size()) return;
  std::size_t k1 = k0;
  double furthest = 0.0;
  for (std::size_t k = k0; k < log.size(); ++k) {
    const double departure = std::abs(log[k].friction_scale - start);
    if (departure <= kSame) break;  // back on the start's grip: the excursion is over
    if (departure > furthest + kSame) furthest = departure, k1 = k;
  }
  std::size_t k2 = k1;
  while (k2 < log.size() && std::abs(log[k2].friction_scale - log[k1].friction_scale) <= kSame) ++k2;
  const auto error = [&](std::size_t k) { return std::abs(log[k].friction_scale_used / log[k].friction_scale - 1.0); };
  std::size_t settled = k2;
  while (settled > k0 && error(settled - 1) <= kSettled) --settled;
  m->friction_change_s = log[k0].t;
  m->friction_change_complete_s = log[k1].t;
  if (settled == k2) return;
  m->friction_settle_after_change_s = log[settled].t - log[k0].t;
  m->friction_settle_after_complete_s = std::max(0.0, log[settled].t - log[k1].t);
  double worst = 0.0;
  for (std::size_t k = std::max(settled, k1); k < k2; ++k) worst = std::max(worst, error(k));
  m->friction_error_after_settle_max_pct = 100.0 * worst;
}

}  // namespace

double wear_imbalance(const Eigen::Ref<const Eigen::VectorXd>& wear_per_module) noexcept {
  if (wear_per_module.size() == 0 || !(wear_per_module.sum() > 0.0)) return 0.0;
  return wear_per_module.maxCoeff() / wear_per_module.mean();
}

RunMetrics compute_metrics(const std::vector<StepRecord>& log, const std::vector<double>& wear_per_module,
                           double frictional_energy, double control_period, double solve_budget) {
  RunMetrics m;
  m.steps = static_cast<int>(log.size());
  double position_sq = 0.0, heading_sq = 0.0;
  std::vector<double> solve_ms;
  double iterations_sum = 0.0;
  solve_ms.reserve(log.size());
  std::vector<double> step_ms;
  step_ms.reserve(log.size());
  double steering_change_sq = 0.0;
  long steering_changes = 0;
  const StepRecord* previous = nullptr;
  for (const StepRecord& record : log) {
    const double e_position = record.position_error();
    const double e_heading = std::abs(record.heading_error());
    position_sq += e_position * e_position;
    heading_sq += e_heading * e_heading;
    m.tracking_max_m = std::max(m.tracking_max_m, e_position);
    m.heading_max_rad = std::max(m.heading_max_rad, e_heading);
    for (const ModuleCommand& command : record.commands) {
      m.steering_effort += control_period * command.steering_rate * command.steering_rate;
    }
    if (previous != nullptr && previous->commands.size() == record.commands.size() && control_period > 0.0) {
      for (std::size_t i = 0; i < record.commands.size(); ++i) {
        const double change = (record.commands[i].steering_rate - previous->commands[i].steering_rate) / control_period;
        steering_change_sq += change * change;
        ++steering_changes;
      }
    }
    previous = &record;
    if (record.solve_time_s >= 0.0) {
      solve_ms.push_back(1e3 * record.solve_time_s);
      iterations_sum += std::max(0, record.solve_iterations);
      if (record.step_time_s < 0.0 && record.solve_time_s > solve_budget) ++m.deadline_misses;
      if (record.solve_late_s > 0.0) ++m.late_solves;
    }
    if (record.step_time_s >= 0.0) {
      step_ms.push_back(1e3 * record.step_time_s);
      if (record.step_time_s > solve_budget) ++m.deadline_misses;
    }
    if (record.work_budget_cut) ++m.work_budget_cuts;
    if (record.source == CommandSource::kTrackingFirst) ++m.tracking_first_steps;
    m.reference_delay_s = record.reference_delay_s;
    if (record.source != CommandSource::kOptimizer && record.source != CommandSource::kTrackingFirst) ++m.fallbacks;
    if (record.source == CommandSource::kSafeStop) ++m.safe_stops;
  }
  if (!log.empty()) {
    m.tracking_rmse_m = std::sqrt(position_sq / static_cast<double>(log.size()));
    m.heading_rmse_rad = std::sqrt(heading_sq / static_cast<double>(log.size()));
  }
  if (steering_changes > 0) m.steering_command_jerk = std::sqrt(steering_change_sq / static_cast<double>(steering_changes));
  m.wear_per_module = wear_per_module;
  m.wear_total = std::accumulate(wear_per_module.begin(), wear_per_module.end(), 0.0);
  m.wear_imbalance = wear_imbalance(Eigen::Map<const Eigen::VectorXd>(wear_per_module.data(),
                                                                       static_cast<Eigen::Index>(wear_per_module.size())));
  m.frictional_energy_J = frictional_energy;
  if (!solve_ms.empty()) {
    m.solve_time_mean_ms = std::accumulate(solve_ms.begin(), solve_ms.end(), 0.0) / static_cast<double>(solve_ms.size());
    m.solve_time_p50_ms = percentile(solve_ms, 50.0);
    m.solve_time_p99_ms = percentile(solve_ms, 99.0);
    m.solve_time_max_ms = *std::max_element(solve_ms.begin(), solve_ms.end());
    m.solve_iterations_mean = iterations_sum / static_cast<double>(solve_ms.size());
  }
  if (!step_ms.empty()) {
    m.step_time_p99_ms = percentile(step_ms, 99.0);
    m.step_time_max_ms = *std::max_element(step_ms.begin(), step_ms.end());
  }
  add_fault_metrics(log, &m);
  add_friction_metrics(log, &m);
  return m;
}

}  // namespace swerve
