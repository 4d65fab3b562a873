#include "swerve/app/run_report.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace swerve {
namespace {

constexpr const char* kBaselineName = "kinematic_baseline";
constexpr const char* kPracticalBaselineName = "practical_baseline";
constexpr const char* kNoWearName = "dynamic_no_wear";
constexpr const char* kWearMpcName = "wear_mpc";

const ControllerRun* find_run(const std::vector<ControllerRun>& runs, const std::string& name) {
  for (const ControllerRun& run : runs) {
    if (run.name == name) return &run;
  }
  return nullptr;
}

// JSON has no NaN: a quantity that cannot be computed is null.
nlohmann::json number_or_null(double value) { return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(); }

// RMSE of `run` over that of `base`; NaN when the base's is 0.
double rmse_ratio(const RunMetrics& run, const RunMetrics& base) {
  return base.tracking_rmse_m > 0.0 ? run.tracking_rmse_m / base.tracking_rmse_m : std::numeric_limits<double>::quiet_NaN();
}

const char* wear_units(const VehicleParams& vehicle) {
  return vehicle.wear.model == WearModelKind::kFrictionalPower ? "J x coefficient (frictional energy)"
                                                               : "N m x coefficient (load x sliding distance)";
}

void write_csv(const ControllerRun& run, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << std::setprecision(9);
  out << "t,x,y,psi,x_ref,y_ref,psi_ref,position_error_m,heading_error_rad,vx,vy,r,solve_time_ms,solve_iterations,source,status,"
         "plan_tracking_cost,plan_wear_cost,plan_cost,initial_guess_cost,friction_scale,friction_scale_used,"
         "prediction_position_error_m,prediction_wear_error";
  const std::size_t n = run.log.empty() ? 0 : run.log.front().modules.size();
  for (std::size_t i = 0; i < n; ++i) {
    out << ",delta_" << i << ",omega_" << i << ",slip_angle_" << i << ",slip_ratio_" << i << ",fx_" << i << ",fy_"
        << i << ",wear_rate_" << i << ",wear_" << i << ",cmd_steering_rate_" << i << ",cmd_wheel_speed_" << i;
  }
  out << "\n";
  for (const StepRecord& r : run.log) {
    out << r.t << ',' << r.pose_world.x() << ',' << r.pose_world.y() << ',' << r.pose_world.z() << ','
        << r.reference_pose_world.x() << ',' << r.reference_pose_world.y() << ',' << r.reference_pose_world.z() << ','
        << r.position_error() << ',' << r.heading_error() << ',' << r.twist_body.x() << ',' << r.twist_body.y() << ','
        << r.twist_body.z() << ',';
    if (r.solve_time_s >= 0.0) out << 1e3 * r.solve_time_s;
    out << ',' << r.solve_iterations << ',' << to_string(r.source) << ',' << to_string(r.solve_status) << ',';
    // The plan's predicted cost (tracking, wear, all parts) and the best initial guess's, so a
    // reader can set the optimiser's trade-off beside the plant's: empty where no optimiser ran.
    if (r.has_plan_cost()) {
      out << r.plan_cost.tracking << ',' << r.plan_cost.wear << ',' << r.plan_cost.total() << ','
          << r.initial_guess_cost;
    } else {
      out << ",,,";
    }
    out << ',' << r.friction_scale << ',' << r.friction_scale_used << ',';
    if (std::isfinite(r.prediction_position_error_m)) out << r.prediction_position_error_m;
    out << ',';
    if (std::isfinite(r.prediction_wear_error)) out << r.prediction_wear_error;
    for (std::size_t i = 0; i < r.modules.size(); ++i) {
      const PlantModuleSample& m = r.modules[i];
      const ModuleCommand& c = r.commands[i];
      out << ',' << m.steering_angle << ',' << m.wheel_speed << ',' << m.slip_angle << ',' << m.slip_ratio << ','
          << m.fx_wheel << ',' << m.fy_wheel << ',' << m.wear_rate << ',' << m.wear << ',' << c.steering_rate << ','
          << c.wheel_speed;
    }
    out << "\n";
  }
  if (!out) throw std::runtime_error(path + ": write failed");
}

std::string fixed(double value, int digits) {
  if (!std::isfinite(value)) return "n/a";
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

}  // namespace

double wear_reduction_pct(const RunMetrics& controller, const RunMetrics& reference) {
  if (!(reference.wear_total > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return 100.0 * (reference.wear_total - controller.wear_total) / reference.wear_total;
}

// [{module, kind}] for every faulty module.
nlohmann::json module_faults_json(const ModuleFaults& faults) {
  nlohmann::json list = nlohmann::json::array();
  for (int i = 0; i < faults.size(); ++i) {
    if (faults[i] != ModuleFault::kNone) list.push_back({{"module", i}, {"kind", to_string(faults[i])}});
  }
  return list;
}

std::string summary_json(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs,
                         const LogFormats& formats) {
  using nlohmann::json;
  json controllers = json::object();
  for (const ControllerRun& run : runs) {
    const RunMetrics& m = run.metrics;
    controllers[run.name] = {
        {"type", to_string(run.kind)},
        {"backend", run.backend.empty() ? json() : json(run.backend)},
        {"wear_weight", run.wear_weight},
        {"effective_wear_weight", run.effective_wear_weight},
        {"completed", run.completed},
        {"failure", run.failure.empty() ? json() : json(run.failure)},
        {"steps", m.steps},
        {"tracking_rmse_m", m.tracking_rmse_m},
        {"tracking_max_m", m.tracking_max_m},
        {"heading_rmse_rad", m.heading_rmse_rad},
        {"heading_max_rad", m.heading_max_rad},
        {"wear_total", m.wear_total},
        {"wear_per_module", m.wear_per_module},
        {"wear_units", wear_units(scenario.vehicle)},
        {"wear_imbalance", m.wear_imbalance},
        {"lifetime_wear_imbalance", m.lifetime_wear_imbalance},
        {"frictional_energy_J", m.frictional_energy_J},
        {"steering_effort_rad2_s", m.steering_effort},
        {"steering_command_jerk_rad_s2", m.steering_command_jerk},
        {"solve_budget_ms", 1e3 * run.solve_budget},
        {"solve_time_mean_ms", m.solve_time_mean_ms},
        {"solve_time_p50_ms", m.solve_time_p50_ms},
        {"solve_time_p99_ms", m.solve_time_p99_ms},
        {"solve_time_max_ms", m.solve_time_max_ms},
        {"step_time_p99_ms", m.step_time_p99_ms},
        {"step_time_max_ms", m.step_time_max_ms},
        {"deadline_misses", m.deadline_misses},
        {"late_solves", m.late_solves},
        {"work_budget_cuts", m.work_budget_cuts},
        {"solve_iterations_mean", m.solve_iterations_mean},
        {"fallbacks", m.fallbacks},
        {"tracking_first_steps", m.tracking_first_steps},
        {"reference_delay_s", m.reference_delay_s},
        {"safe_stops", m.safe_stops},
        {"fault_onset_s", m.fault_onset_s >= 0.0 ? json(m.fault_onset_s) : json()},
        {"fault_detection_cycles", m.fault_detection_cycles >= 0 ? json(m.fault_detection_cycles) : json()},
        {"tracking_rmse_after_fault_known_m",
         m.tracking_rmse_after_fault_known_m >= 0.0 ? json(m.tracking_rmse_after_fault_known_m) : json()},
        {"false_fault_alarms", m.false_fault_alarms},
        {"module_faults", module_faults_json(run.module_faults)},
        {"friction_change_s", m.friction_change_s >= 0.0 ? json(m.friction_change_s) : json()},
        {"friction_change_complete_s", m.friction_change_complete_s >= 0.0 ? json(m.friction_change_complete_s) : json()},
        {"friction_settle_after_change_s",
         m.friction_settle_after_change_s >= 0.0 ? json(m.friction_settle_after_change_s) : json()},
        {"friction_settle_after_complete_s",
         m.friction_settle_after_complete_s >= 0.0 ? json(m.friction_settle_after_complete_s) : json()},
        {"friction_error_after_settle_max_pct",
         m.friction_error_after_settle_max_pct >= 0.0 ? json(m.friction_error_after_settle_max_pct) : json()},
        {"lost_motions", run.lost_motions.empty() ? json() : json(run.lost_motions)},
        {"log_csv", formats.csv ? nlohmann::json(run.name + ".csv") : nlohmann::json()},
    };
  }
  json comparison = json::object();
  const ControllerRun* wear = find_run(runs, kWearMpcName);
  const ControllerRun* base = find_run(runs, kBaselineName);
  const ControllerRun* no_wear = find_run(runs, kNoWearName);
  comparison["wear_reduction_pct"] = wear && base ? number_or_null(wear_reduction_pct(wear->metrics, base->metrics)) : json();
  comparison["tracking_rmse_ratio"] = wear && base ? number_or_null(rmse_ratio(wear->metrics, base->metrics)) : json();
  // Against the practical controller (configs/controllers/practical_baseline.yaml) when the scenario runs it.
  const ControllerRun* practical = find_run(runs, kPracticalBaselineName);
  comparison["wear_reduction_vs_practical_pct"] =
      wear && practical ? number_or_null(wear_reduction_pct(wear->metrics, practical->metrics)) : json();
  comparison["tracking_rmse_ratio_vs_practical"] =
      wear && practical ? number_or_null(rmse_ratio(wear->metrics, practical->metrics)) : json();
  comparison["wear_reduction_vs_no_wear_pct"] =
      wear && no_wear ? number_or_null(wear_reduction_pct(wear->metrics, no_wear->metrics)) : json();
  comparison["paper_wear_reduction_pct"] =
      scenario.paper_wear_reduction_pct ? json(*scenario.paper_wear_reduction_pct) : json();

  json modules = json::array();
  for (const Eigen::Vector2d& p : scenario.vehicle.layout.positions_body()) modules.push_back({p.x(), p.y()});
  const json summary = {
      {"scenario", scenario.name},
      {"description", scenario.description},
      {"vehicle", scenario.vehicle.name},
      {"reference", scenario.reference_description},
      {"seed", scenario.simulator.seed},
      {"initial_module_wear", scenario.simulator.initial_module_wear},
      {"duration_s", scenario.duration},
      {"control_period_s", scenario.simulator.control_period},
      {"module_positions_m", modules},
      {"controllers", controllers},
      {"comparison", comparison},
  };
  // File and directory names come from the command line and need not be UTF-8: replace bad bytes
  // rather than throw after the run (config text itself is checked at load).
  return summary.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
}

void prepare_output_directory(const std::string& out_dir) {
  namespace fs = std::filesystem;
  const std::string shown = printable_value(out_dir, std::string::npos);
  std::error_code error;
  fs::create_directories(out_dir, error);
  if (error || !fs::is_directory(out_dir)) {
    throw std::runtime_error(shown + ": cannot create the output directory" +
                             (error ? " (" + error.message() + ")" : " (it exists and is not a directory)"));
  }
  const fs::path probe = fs::path(out_dir) / ".swerve-mpc-write-probe";
  {
    std::ofstream out(probe);
    if (!out || !(out << "probe\n") || !out.flush()) {
      throw std::runtime_error(shown + ": the output directory is not writable");
    }
  }
  fs::remove(probe, error);
}

void write_run_outputs(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs,
                       const std::string& out_dir, const LogFormats& formats) {
  namespace fs = std::filesystem;
  std::error_code error;
  prepare_output_directory(out_dir);
  const fs::path summary_path = fs::path(out_dir) / "summary.json";
  fs::remove(summary_path, error);  // a stale summary must not describe the new, partial logs
  if (formats.csv) {
    for (const ControllerRun& run : runs) write_csv(run, (fs::path(out_dir) / (run.name + ".csv")).string());
  }
  const LogContext context{scenario.name, scenario.vehicle.layout.wheel_radius()};
  if (formats.wpilog) write_wpilog(context, runs, (fs::path(out_dir) / "run.wpilog").string());
  if (formats.mcap) write_mcap(context, runs, (fs::path(out_dir) / "run.mcap").string());
  const fs::path temporary = fs::path(out_dir) / ".summary.json.tmp";
  {
    std::ofstream out(temporary);
    if (!out) throw std::runtime_error(temporary.string() + ": cannot open for writing");
    out << summary_json(scenario, runs, formats) << "\n";
    if (!out) throw std::runtime_error(temporary.string() + ": write failed");
  }
  fs::rename(temporary, summary_path, error);
  if (error) throw std::runtime_error(summary_path.string() + ": cannot rename into place (" + error.message() + ")");
}

std::string comparison_table(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs) {
  std::ostringstream out;
  out << scenario.name << ": " << scenario.vehicle.name << " (" << scenario.vehicle.layout.size() << " modules), "
      << scenario.reference_description << ", " << fixed(scenario.duration, 1) << " s, seed "
      << scenario.simulator.seed << "\n";
  const ControllerRun* base = find_run(runs, kBaselineName);
  out << std::left << std::setw(20) << "controller" << std::right << std::setw(10) << "rmse [m]" << std::setw(10)
      << "max [m]" << std::setw(14) << "psi rms [deg]" << std::setw(14) << "wear total" << std::setw(12)
      << "vs base [%]" << std::setw(12) << "p99 [ms]" << std::setw(8) << "misses" << std::setw(11) << "fallbacks"
      << "\n";
  for (const ControllerRun& run : runs) {
    const RunMetrics& m = run.metrics;
    const double reduction = base ? wear_reduction_pct(m, base->metrics) : std::numeric_limits<double>::quiet_NaN();
    out << std::left << std::setw(20) << run.name << std::right << std::setw(10) << fixed(m.tracking_rmse_m, 4)
        << std::setw(10) << fixed(m.tracking_max_m, 4) << std::setw(14) << fixed(m.heading_rmse_rad * 180.0 / kPi, 3)
        << std::setw(14) << fixed(m.wear_total, 2) << std::setw(12)
        << (base && &run != base ? fixed(-reduction, 2) : std::string("-")) << std::setw(12)
        << fixed(m.solve_time_p99_ms, 2) << std::setw(8) << m.deadline_misses << std::setw(11) << m.fallbacks;
    if (!run.completed) out << "  (" << run.failure << ")";
    out << "\n";
  }
  for (const ControllerRun& run : runs) {
    if (run.metrics.reference_delay_s > 0.0) {
      out << run.name << ": the reference was held " << fixed(run.metrics.reference_delay_s, 2)
          << " s while its modules pre-aligned (late by that much; its tracking is judged on its own clock)\n";
    }
  }
  const ControllerRun* wear = find_run(runs, kWearMpcName);
  // "wear_mpc vs <baseline>: wear X %, tracking RMSE ratio Y" (no line end).
  const auto against = [&](const ControllerRun& baseline) {
    out << "wear_mpc vs " << baseline.name << ": wear " << fixed(-wear_reduction_pct(wear->metrics, baseline.metrics), 2)
        << " %, tracking RMSE ratio " << fixed(rmse_ratio(wear->metrics, baseline.metrics), 3);
  };
  if (wear && base) {
    against(*base);
    if (scenario.paper_wear_reduction_pct) out << "  (paper: wear -" << fixed(*scenario.paper_wear_reduction_pct, 2) << " %)";
    out << "\n";
  }
  const ControllerRun* practical = find_run(runs, kPracticalBaselineName);
  if (wear && practical) {
    against(*practical);
    out << "\n";
  }
  const ControllerRun* no_wear = find_run(runs, kNoWearName);
  if (wear && no_wear) {
    out << "wear_mpc vs dynamic_no_wear:    wear " << fixed(-wear_reduction_pct(wear->metrics, no_wear->metrics), 2)
        << " %\n";
  }
  return out.str();
}

}  // namespace swerve
