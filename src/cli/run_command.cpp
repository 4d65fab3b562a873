// `swerve-mpc run SCENARIO.yaml`: runs the scenario's controllers on the simulated plant, prints the
// comparison table and writes per-step CSV logs and summary.json. `swerve-mpc sweep` runs the
// wear-aware controller over a list of wear weights and writes the wear-versus-tracking table.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "command_registry.hpp"
#include "swerve/config/scenario_config.hpp"
#include "swerve/sim/run_report.hpp"

namespace swerve::cli {
namespace {

struct RunArguments {
  std::string scenario_file;
  std::string out_dir;
  std::vector<std::string> controllers;
  std::int64_t seed = -1;
  std::string backend;
  bool quiet = false;
};

void declare_common(CLI::App& app, RunArguments* a) {
  app.add_option("scenario", a->scenario_file, "Scenario YAML (configs/scenarios/)")->required();
  app.add_option("-o,--out", a->out_dir, "Output directory [out/<scenario name>]");
  app.add_option("--seed", a->seed, "Simulator seed (overrides the scenario's)")->check(CLI::NonNegativeNumber);
  app.add_option("--backend", a->backend, "Solver backend of the wear-aware controllers (sa, ipopt, nlopt, ceres)");
  app.add_flag("-q,--quiet", a->quiet, "No progress bar");
}

RunOverrides overrides_of(const RunArguments& a) {
  RunOverrides o;
  o.controllers = a.controllers;
  if (a.seed >= 0) o.seed = static_cast<std::uint64_t>(a.seed);
  if (!a.backend.empty()) o.backend = a.backend;
  return o;
}

// A one-line progress bar on a terminal; nothing when stderr is not one (logs stay clean).
ProgressCallback progress_bar(const ScenarioConfig& scenario, bool quiet) {
  if (quiet || !isatty(STDERR_FILENO)) return {};
  return [&scenario](std::size_t index, int done, int total) {
    if (done % 10 != 0 && done != total) return;
    const int width = 30;
    const int filled = total > 0 ? width * done / total : width;
    std::fprintf(stderr, "\r  %-20s [%s%s] %3d%%", scenario.controllers[index].name.c_str(),
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(width - filled), '.').c_str(), total > 0 ? 100 * done / total : 100);
    if (done == total) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

std::string out_dir_of(const RunArguments& a, const ScenarioConfig& s) {
  return a.out_dir.empty() ? "out/" + s.name : a.out_dir;
}

int run(const RunArguments& a) {
  const ScenarioConfig scenario = apply_overrides(load_scenario_config_file(a.scenario_file), overrides_of(a));
  const std::string out_dir = out_dir_of(a, scenario);
  std::vector<ControllerRun> runs;
  const ProgressCallback progress = progress_bar(scenario, a.quiet);
  for (std::size_t i = 0; i < scenario.controllers.size(); ++i) {
    runs.push_back(run_controller(scenario, scenario.controllers[i], progress, i));
  }
  write_run_outputs(scenario, runs, out_dir);
  std::cout << comparison_table(scenario, runs) << "written: " << out_dir << "/summary.json and "
            << runs.size() << " per-step CSV logs\n";
  for (const ControllerRun& r : runs) {
    if (!r.completed) {
      std::cerr << "swerve-mpc run: " << r.name << ": " << r.failure << "\n";
      return kExitFailure;
    }
  }
  return kExitOk;
}

int sweep(const RunArguments& a, const std::vector<double>& lambdas) {
  const ScenarioConfig loaded = load_scenario_config_file(a.scenario_file);
  RunOverrides base_overrides = overrides_of(a);
  const std::string out_dir = out_dir_of(a, loaded) + "/sweep";
  std::filesystem::create_directories(out_dir);
  // The baseline once, then the wear-aware controller at every lambda.
  RunOverrides baseline_only = base_overrides;
  baseline_only.controllers = {"kinematic_baseline"};
  const ScenarioConfig baseline_scenario = apply_overrides(loaded, baseline_only);
  const ControllerRun baseline = run_controller(baseline_scenario, baseline_scenario.controllers.front());
  nlohmann::json points = nlohmann::json::array();
  std::printf("%-12s %12s %14s %14s %10s\n", "wear_weight", "rmse [m]", "wear total", "vs base [%]", "p99 [ms]");
  std::printf("%-12s %12.4f %14.2f %14s %10s\n", "baseline", baseline.metrics.tracking_rmse_m,
              baseline.metrics.wear_total, "-", "-");
  for (const double lambda : lambdas) {
    RunOverrides o = base_overrides;
    o.controllers = {"wear_mpc"};
    o.wear_weight = lambda;
    const ScenarioConfig s = apply_overrides(loaded, o);
    const ControllerRun r = run_controller(s, s.controllers.front());
    const double reduction = wear_reduction_pct(r.metrics, baseline.metrics);
    std::printf("%-12g %12.4f %14.2f %14.2f %10.2f%s\n", lambda, r.metrics.tracking_rmse_m, r.metrics.wear_total,
                -reduction, r.metrics.solve_time_p99_ms, r.completed ? "" : "  (plant diverged)");
    points.push_back({{"wear_weight", lambda},
                      {"tracking_rmse_m", r.metrics.tracking_rmse_m},
                      {"wear_total", r.metrics.wear_total},
                      {"wear_reduction_pct", reduction},
                      {"solve_time_p99_ms", r.metrics.solve_time_p99_ms},
                      {"completed", r.completed}});
  }
  const nlohmann::json sweep_json = {
      {"scenario", loaded.name},
      {"points", points},
      {"baseline", {{"tracking_rmse_m", baseline.metrics.tracking_rmse_m}, {"wear_total", baseline.metrics.wear_total}}}};
  // The plot script reads a summary beside the sweep for the scenario's name and units.
  std::ofstream(out_dir + "/sweep.json") << sweep_json.dump(2) << "\n";
  write_run_outputs(baseline_scenario, {baseline}, out_dir);
  std::cout << "written: " << out_dir << "/sweep.json\n";
  return kExitOk;
}

}  // namespace

Command make_run_command() {
  return {"run", "Run a scenario: every controller on the simulated plant, then the comparison table",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<RunArguments>();
            declare_common(app, a.get());
            app.add_option("--controllers", a->controllers, "Run only these controllers (comma-separated)")
                ->delimiter(',');
            return [a]() { return run(*a); };
          }};
}

Command make_sweep_command() {
  return {"sweep", "Run the wear-aware controller over a list of wear weights (the wear/tracking trade-off)",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<RunArguments>();
            auto lambdas = std::make_shared<std::vector<double>>();
            declare_common(app, a.get());
            app.add_option("--lambda", *lambdas, "Wear weights, comma-separated")->delimiter(',')->required()
                ->check(CLI::NonNegativeNumber);
            return [a, lambdas]() { return sweep(*a, *lambdas); };
          }};
}

}  // namespace swerve::cli
