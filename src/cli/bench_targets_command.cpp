// `swerve-mpc bench-targets`: the real-time report per embedded target. For every target
// and its tuned controller (configs/controllers/tuned/<target>.yaml, else the default), the paper
// pair in closed loop at the target's period and translated budget: step time p50/p99/max in the
// target's milliseconds against its budget, proposals per solve, misses, and a pass/fail line.
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "command_registry.hpp"
#include "swerve/app/controller_config.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/app/tuning.hpp"

namespace swerve::cli {
namespace {

struct BenchTargetsArguments {
  std::vector<std::string> target_files{"configs/targets/default.yaml", "configs/targets/raspberry_pi_4.yaml",
                                        "configs/targets/jetson_orin_nano.yaml"};
  std::vector<std::string> scenario_files{"configs/scenarios/curve.yaml", "configs/scenarios/offset60.yaml"};
  std::string tuned_dir = "configs/controllers/tuned";
  std::string default_controller = "configs/controllers/default.yaml";
  WorkClockRates work_clock;  // per_read_s 0: the steady clock
};

int bench_targets(const BenchTargetsArguments& a) {
  std::vector<ScenarioConfig> scenarios;
  for (const std::string& file : a.scenario_files) scenarios.push_back(load_scenario_config_file(file));
  std::optional<WorkClock> work_clock = work_clock_for(a.work_clock);
  if (work_clock) std::printf("%s\n", work_clock_notice(a.work_clock).c_str());
  std::printf("%-18s %-24s %-16s %9s %9s %9s %9s %9s %10s %7s %5s\n", "target", "controller", "scenario", "period",
              "budget", "step p50", "step p99", "step max", "proposals", "misses", "once");
  bool all_pass = true;
  for (const std::string& target_file : a.target_files) {
    const TargetConfig target = load_target_config_file(target_file);
    const std::string tuned = a.tuned_dir + "/" + std::filesystem::path(target_file).stem().string() + ".yaml";
    const std::string controller_file = std::filesystem::exists(tuned) ? tuned : a.default_controller;
    const ControllerConfig controller = load_controller_config_file(controller_file);
    const std::vector<RealTimeRow> rows =
        measure_real_time(controller, target, scenarios, work_clock ? &*work_clock : nullptr);
    // The file's name in the table (a path would be cut); the whole path in the target's verdict.
    const std::string controller_name = std::filesystem::path(controller_file).filename().string();
    bool pass = true;
    for (const RealTimeRow& row : rows) {
      std::printf("%-18s %-24s %-16.16s %7.1fms %7.1fms %7.2fms %7.2fms %7.2fms %10.0f %7d %5d%s\n",
                  target.name.c_str(), controller_name.c_str(), row.scenario.c_str(), row.period_ms, row.budget_ms,
                  row.step_p50_ms, row.step_p99_ms, row.step_max_ms, row.proposals_median, row.deadline_misses,
                  row.unconfirmed_misses, row.passes() ? "" : "  (fails)");
      pass = pass && row.passes();
    }
    const double period_ms = rows.empty() ? 1e3 * target.control_period : rows.front().period_ms;
    const double budget_ms = rows.empty() ? 1e3 * target.solve_budget : rows.front().budget_ms;
    std::printf("%s: %s (p99 step <= %.1f ms of every %.0f ms cycle and no deadline miss on every scenario, a "
                "run that missed run again and only misses that recur counted (once: those that did not), at "
                "%.2fx this machine's time; controller %s)\n",
                target.name.c_str(), pass ? "pass" : "FAIL", budget_ms, period_ms, target.cpu_slowdown,
                controller_file.c_str());
    all_pass = all_pass && pass;
  }
  return all_pass ? kExitOk : kExitFailure;
}

}  // namespace

Command make_bench_targets_command() {
  return {"bench-targets",
          "The real-time report per embedded target: its tuned controller on the paper pair, step times against its "
          "budget",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<BenchTargetsArguments>();
            app.add_option("--targets", a->target_files, "Target YAMLs, comma-separated")
                ->delimiter(',')
                ->capture_default_str();
            app.add_option("--scenarios", a->scenario_files, "Scenario YAMLs, comma-separated")
                ->delimiter(',')
                ->capture_default_str();
            app.add_option("--tuned-dir", a->tuned_dir,
                           "Where each target's tuned controller is (<dir>/<target file name>.yaml)")
                ->capture_default_str();
            app.add_option("--controller", a->default_controller, "The controller for targets without a tuned one")
                ->capture_default_str();
            add_work_clock_option(app, &a->work_clock);
            return [a]() { return bench_targets(*a); };
          }};
}

}  // namespace swerve::cli
