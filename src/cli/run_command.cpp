// `swerve-mpc run SCENARIO.yaml`: runs the scenario's controllers on the simulated plant, prints the
// comparison table and writes per-step CSV logs and summary.json. `swerve-mpc sweep` runs the
// wear-aware controller over wear weights or tolerances (app/sweep.hpp) and writes the table.
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>

#include "command_registry.hpp"
#include "swerve/core/error_text.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/run_report.hpp"
#include "swerve/app/sweep.hpp"
#include "swerve/solvers/solver_factory.hpp"

namespace swerve::cli {
namespace {

struct RunArguments {
  std::string scenario_file;
  std::string out_dir;
  std::vector<std::string> controllers;
  std::string seed;  // checked by seed_value(); kept as text so no conversion can clamp or wrap it
  std::string backend;
  WorkClockRates work_clock;  // per_read_s 0: the steady clock
  bool quiet = false;
  std::string logs = "csv";   // --log: checked by parse_log_formats
};

// The seed a --seed value names: a decimal integer in [0, 2^64 - 1], the simulator's seed type;
// nullopt for anything else (a sign, a fraction, trailing text, too many digits).
std::optional<std::uint64_t> seed_value(const std::string& text) {
  std::uint64_t value = 0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (text.empty() || error != std::errc() || stop != end) return std::nullopt;
  return value;
}

const CLI::Validator kSeedRule(
    [](std::string& text) -> std::string {
      if (seed_value(text)) return "";
      return "'" + printable_value(text) + "': must be an integer in [0, " +
             std::to_string(std::numeric_limits<std::uint64_t>::max()) + "]";
    },
    "SEED");

// The factory's list of built backends is the rule; a typo is a command-line error, found before
// anything is loaded.
const CLI::Validator kBackendRule(
    [](std::string& name) -> std::string {
      const std::vector<std::string>& built = built_backends();
      if (std::find(built.begin(), built.end(), name) != built.end()) return "";
      return "'" + printable_value(name) + "' was not built (built: " + built_backends_text() + ")";
    },
    "BACKEND");

void declare_common(CLI::App& app, RunArguments* a) {
  app.add_option("scenario", a->scenario_file, "Scenario YAML (configs/scenarios/)")->required();
  app.add_option("-o,--out", a->out_dir, "Output directory [out/<scenario name>]");
  app.add_option("--seed", a->seed, "Simulator seed, an integer >= 0 (overrides the scenario's)")->check(kSeedRule);
  app.add_option("--backend", a->backend, "Solver backend of the wear-aware controllers (sa, rti, ipopt, nlopt, ceres)")
      ->check(kBackendRule);
  app.add_flag("-q,--quiet", a->quiet, "No progress bar");
}

RunOverrides overrides_of(const RunArguments& a) {
  RunOverrides o;
  o.controllers = a.controllers;
  if (!a.seed.empty()) o.seed = seed_value(a.seed);
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

// The scenario with the command line's overrides; an override that does not fit the scenario (an
// unknown or repeated --controllers name) is a command-line error.
ScenarioConfig with_overrides(const ScenarioConfig& loaded, const RunOverrides& overrides) {
  try {
    return apply_overrides(loaded, overrides);
  } catch (const OverrideError& error) {
    throw UsageError(error.what());
  }
}

// Fails before any simulation when the output directory cannot be written.
void prepare_out_dir(const std::string& out_dir) {
  try {
    prepare_output_directory(out_dir);
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(std::string("--out ") + error.what() + "; nothing was run");
  }
}

int run(const RunArguments& a) {
  // Checked before the runs, so a typo costs no run.
  const LogFormats formats = [&] {
    try {
      return parse_log_formats(a.logs);
    } catch (const ConfigError& error) {
      throw UsageError(error.what());
    }
  }();
  const ScenarioConfig scenario = with_overrides(load_scenario_config_file(a.scenario_file), overrides_of(a));
  const std::string out_dir = out_dir_of(a, scenario);
  prepare_out_dir(out_dir);
  std::vector<ControllerRun> runs;
  const ProgressCallback progress = progress_bar(scenario, a.quiet);
  for (std::size_t i = 0; i < scenario.controllers.size(); ++i) {
    // Each controller on its own work clock, from the same start, when one is asked for.
    std::optional<WorkClock> work_clock = work_clock_for(a.work_clock);
    runs.push_back(run_controller(scenario, scenario.controllers[i], progress, i, work_clock ? &*work_clock : nullptr));
  }
  write_run_outputs(scenario, runs, out_dir, formats);
  std::cout << comparison_table(scenario, runs);
  if (a.work_clock.per_read_s > 0.0) std::cout << work_clock_notice(a.work_clock) << "\n";
  std::cout << "written: " << out_dir << "/summary.json";
  if (formats.csv) std::cout << ", " << runs.size() << " per-step CSV logs";
  if (formats.wpilog) std::cout << ", run.wpilog";
  if (formats.mcap) std::cout << ", run.mcap";
  std::cout << "\n";
  for (const ControllerRun& r : runs) {
    if (!r.completed) {
      std::cerr << "swerve-mpc run: " << r.name << ": " << r.failure << "\n";
      return kExitFailure;
    }
  }
  return kExitOk;
}

int sweep(const RunArguments& a, const std::vector<SweepPoint>& sweep_points, const Shard& shard) {
  const ScenarioConfig loaded = load_scenario_config_file(a.scenario_file);
  const std::string out_dir = out_dir_of(a, loaded) + "/sweep";
  prepare_out_dir(out_dir);
  std::cout << sweep_table_header();
  RunMetrics baseline_metrics;
  // Each row as soon as its run ends.
  const SweepCallback print_row = [&baseline_metrics](const SweepPoint* point, const ControllerRun& r) {
    if (point == nullptr) baseline_metrics = r.metrics;
    std::cout << sweep_table_row(point, r, baseline_metrics) << std::flush;
  };
  SweepResult result = [&] {
    try {
      return run_sweep(loaded, overrides_of(a), sweep_points, print_row, shard, a.work_clock);
    } catch (const OverrideError& error) {
      throw UsageError(error.what());
    }
  }();
  if (result.practical) std::cout << sweep_practical_row(*result.practical, baseline_metrics);
  std::vector<ControllerRun> baselines{result.baseline};
  if (result.practical) baselines.push_back(*result.practical);
  if (!shard.whole()) {
    // Shard 0 keeps the baselines' logs, which merge copies; every shard keeps its record.
    if (shard.index == 0) write_run_outputs(result.baseline_scenario, baselines, out_dir);
    const std::string shard_path = out_dir + "/" + kShardFileName;
    const std::string overrides = "seed " + (a.seed.empty() ? std::string("(scenario's)") : a.seed) + ", backend " +
                                  (a.backend.empty() ? std::string("(controller's)") : a.backend);
    write_sweep_shard({loaded.name, sweep_points, overrides, a.work_clock}, result, shard, shard_path);
    std::cout << "sweep shard " << shard.text() << ": " << result.points.size() << " of " << sweep_points.size()
              << " points\nwritten: " << shard_path << " (swerve-mpc merge <the shards' folders> -o <out>)\n";
    return kExitOk;
  }
  // The plot script reads a summary beside the sweep for the scenario's name and units.
  write_sweep_json(out_dir, loaded.name, result.baseline, result.points, result.practical);
  write_run_outputs(result.baseline_scenario, baselines, out_dir);
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
            add_work_clock_option(app, &a->work_clock);
            app.add_option("--log", a->logs,
                           "Per-step logs, comma-separated: csv (one file per controller), wpilog (WPILib "
                           "DataLog for AdvantageScope), mcap (for Foxglove) [csv]");
            return [a]() { return run(*a); };
          }};
}

Command make_sweep_command() {
  return {"sweep",
          "Run the wear-aware controller over wear weights or tracking tolerances (the wear/tracking trade-off)",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<RunArguments>();
            auto lambdas = std::make_shared<std::vector<double>>();
            auto tolerances = std::make_shared<std::vector<double>>();
            auto heading = std::make_shared<double>(0.5 * kPi / 180.0);
            declare_common(app, a.get());
            auto* lambda_option = app.add_option("--lambda", *lambdas, "Wear weights, comma-separated")
                                      ->delimiter(',')
                                      ->check(CLI::NonNegativeNumber);
            auto* tolerance_option =
                app.add_option("--tolerance", *tolerances,
                               "Position tolerances in m, comma-separated (tracking-tolerance mode)")
                    ->delimiter(',')
                    ->check(CLI::PositiveNumber);
            app.add_option("--heading-tolerance", *heading, "Heading tolerance in rad with --tolerance [0.5 deg]")
                ->check(CLI::PositiveNumber);
            lambda_option->excludes(tolerance_option);
            add_work_clock_option(app, &a->work_clock);
            auto shard_text = std::make_shared<std::string>();
            app.add_option("--shard", *shard_text,
                           "I/N: run the points whose index is I modulo N (and the baseline) and write "
                           "<out>/sweep/shard.json for swerve-mpc merge");
            return [a, lambdas, tolerances, heading, shard_text]() {
              Shard shard;
              try {
                if (!shard_text->empty()) shard = parse_shard(*shard_text);
              } catch (const ConfigError& error) {
                throw UsageError(std::string("sweep: ") + error.what());
              }
              if (lambdas->empty() == tolerances->empty()) {
                throw UsageError("sweep: give exactly one of --lambda and --tolerance");
              }
              std::vector<SweepPoint> points;
              for (const double lambda : *lambdas) points.push_back({lambda, std::nullopt});
              for (const double position : *tolerances) {
                TrackingTolerance t;
                t.position = position;
                t.heading = *heading;
                points.push_back({std::nullopt, t});
              }
              return sweep(*a, points, shard);
            };
          }};
}

}  // namespace swerve::cli
