// `swerve-mpc tune`: tunes the wear-aware controller for an embedded target (swerve/app/tuning.hpp).
// With --scenarios: by closed-loop quality against the kinematic baseline (backend, horizon, SA knots),
// printing every candidate and the winner, and writing its YAML (--write). Without: sizing only,
// the optimiser proposals per solve at each horizon.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "command_registry.hpp"
#include "swerve/app/run_report.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/tuning.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/core/error_text.hpp"

namespace swerve::cli {
namespace {

struct TuneArguments {
  std::string vehicle_file = "configs/vehicles/paper_ms_agv.yaml";
  std::string controller_file = "configs/controllers/default.yaml";
  std::string target_file = "configs/targets/default.yaml";
  TuningOptions options;
  std::vector<std::string> scenario_files;  // quality mode when given
  std::vector<int> knots{3, 6};
  std::vector<std::string> backends;        // quality; empty: the controller file's own
  std::vector<double> margins;              // deadline margins (quality); empty: the file's own
  std::vector<double> dts;                  // prediction steps (quality); empty: the target's control period
  std::vector<double> periods;              // control periods (quality), each one the target allows; empty: its own
  std::vector<std::uint64_t> seeds;         // simulator seeds (quality); empty: each scenario's own
  std::string write_file;                   // the winner's controller YAML
  std::string out_dir;                      // tune.json
  WorkClockRates work_clock;  // per_read_s 0: the steady clock
  bool horizons_given = false;
  bool quiet = false;
  bool accept_tracking_loss = false;  // --write the closest candidate when none keeps the bounds
  bool force = false;                 // --write may replace an existing file
};

// Before a search of many minutes, not after it: --write names a file that may be written (an
// existing one only with --force) in a directory that exists and is writable.
void check_write_file(const std::string& path, bool force) {
  namespace fs = std::filesystem;
  const std::string shown = "--write " + printable_value(path, std::string::npos);
  std::error_code error;
  const fs::path file(path);
  if (fs::is_directory(file, error)) throw std::runtime_error(shown + ": is a directory; nothing was run");
  if (fs::exists(file, error) && !force)
    throw std::runtime_error(shown + ": exists (--force replaces it); nothing was run");
  const fs::path directory = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (!fs::is_directory(directory, error) || access(directory.c_str(), W_OK) != 0) {
    throw std::runtime_error(shown + ": cannot write into " +
                             printable_value(directory.string(), std::string::npos) + "; nothing was run");
  }
}

// "sa, horizon 10, dt 0.05 s, 3 knots" / "nlopt, horizon 10, dt 0.1 s": knots are the sa backend's alone;
// a candidate at another of the target's periods adds ", every 20 ms".
std::string describe(const TuningCandidate& c) {
  char dt[32];
  std::snprintf(dt, sizeof dt, "%g", c.dt);
  std::string text = c.backend + ", horizon " + std::to_string(c.horizon) + ", dt " + dt + " s";
  if (c.backend == "sa") text += ", " + std::to_string(c.knots) + " knots";
  if (c.control_period > 0.0) {  // another of the target's periods than its own
    char period[32];
    std::snprintf(period, sizeof period, "%g", 1e3 * c.control_period);
    text += ", every " + std::string(period) + " ms";
  }
  return text;
}

nlohmann::json to_json(const QualityTuningResult& result, const TargetConfig& target) {
  nlohmann::json rows = nlohmann::json::array();
  for (const CandidateScore& c : result.candidates) {
    nlohmann::json scenarios = nlohmann::json::array();
    for (const ScenarioScore& s : c.scenarios) {
      scenarios.push_back({{"scenario", s.scenario}, {"wear_ratio", s.wear_ratio}, {"rmse_m", s.rmse_m},
                           {"baseline_rmse_m", s.baseline_rmse_m},
                           {"target_period_baseline_rmse_m", s.target_period_baseline_rmse_m},
                           {"heading_rmse_rad", s.heading_rmse_rad},
                           {"baseline_heading_rmse_rad", s.baseline_heading_rmse_rad},
                           {"step_p99_target_ms", s.step_p99_ms * target.cpu_slowdown},
                           {"deadline_misses", s.deadline_misses},
                           {"unconfirmed_misses", s.unconfirmed_misses}, {"fallbacks", s.fallbacks},
                           {"acceptable", s.acceptable()}});
    }
    rows.push_back({{"backend", c.candidate.backend}, {"horizon", c.candidate.horizon},
                    {"control_period_s", c.candidate.period_at(target.control_period)},
                    {"dt_s", c.candidate.step_at(target.control_period)},
                    {"knots", c.candidate.knots},
                    {"deadline_margin", c.candidate.deadline_margin}, {"finalist", c.finalist},
                    {"geomean_wear_ratio", c.geomean_wear_ratio}, {"unacceptable", c.unacceptable},
                    {"no_worse_than_own", result.incumbent >= 0 && &c != &result.candidates[static_cast<std::size_t>(result.incumbent)] &&
                                              no_worse_on_every_scenario(c, result.candidates[static_cast<std::size_t>(result.incumbent)])},
                    {"scenarios", scenarios}});
  }
  return {{"target", target.name},
          {"control_period_s", target.control_period},
          {"solve_budget_s", target.solve_budget},
          {"cpu_slowdown", target.cpu_slowdown},
          {"budget_here_s", result.budget_here_s},
          {"rule", QualityTuningResult::rule()},
          {"best", result.best},
          {"incumbent", result.incumbent},
          {"closest_rule", QualityTuningResult::closest_rule()},
          {"closest", result.closest},
          {"candidates", rows}};
}

// The tuner's options from the command line, its controllers on `clock` (nullptr: the steady clock).
QualityTuningOptions quality_options_of(const TuneArguments& a, const Clock* clock) {
  QualityTuningOptions options;
  options.horizons = a.horizons_given ? a.options.horizons : std::vector<int>{10, 15, 20, 30};
  options.knots = a.knots;
  options.backends = a.backends;
  options.deadline_margins = a.margins;
  options.seeds = a.seeds;
  options.dts = a.dts;
  options.periods = a.periods;
  options.clock = clock;
  return options;
}

// What will be tried, on which budget, before the (long) search starts.
void print_tuning_plan(const ControllerConfig& controller, const TargetConfig& target,
                       const QualityTuningOptions& options, std::size_t scenarios, const TuneArguments& a) {
  const std::size_t candidates = quality_candidates(controller, options, target.control_period).candidates.size();
  std::printf("tune: controller %s, target %s: %.0f ms of every %.0f ms cycle at %.2fx this machine's time "
              "(%.2f ms here), %zu candidates on %zu scenarios\n",
              controller.name.c_str(), target.name.c_str(), 1e3 * target.solve_budget, 1e3 * target.control_period,
              target.cpu_slowdown, 1e3 * target.solve_budget / target.cpu_slowdown, candidates, scenarios);
  for (const double period : options.periods) {
    if (std::abs(period - target.control_period) < 1e-9) continue;
    std::printf("also at a %.0f ms cycle with %.1f ms (%.2f ms here); every wear ratio is against the baseline at "
                "%.0f ms, the tracking against the better of the baseline there and at the candidate's cycle\n",
                1e3 * period, 1e3 * *target.budget_at(period), 1e3 * *target.budget_at(period) / target.cpu_slowdown,
                1e3 * target.control_period);
  }
  if (!options.seeds.empty()) std::printf("each on %zu seeds: medians per scenario\n", options.seeds.size());
  if (options.clock != nullptr) std::printf("%s\n", work_clock_notice(a.work_clock).c_str());
  std::fflush(stdout);
}

// One row per candidate: per scenario wear ratio and RMSE ratio, then the summary.
void print_candidate_table(const QualityTuningResult& result, const std::vector<ScenarioConfig>& scenarios,
                           const TargetConfig& target) {
  std::printf("%7s %7s %6s %6s %5s %6s", "backend", "horizon", "period", "dt", "knots", "margin");
  for (const ScenarioConfig& s : scenarios) std::printf("  %-22.22s", s.name.c_str());
  std::printf(" %10s %8s %6s %14s\n", "geo. wear", "misses", "once", "unacceptable");
  for (std::size_t i = 0; i < result.candidates.size(); ++i) {
    const CandidateScore& c = result.candidates[i];
    std::printf("%7s %7d %6g %6g %5s %6.2f", c.candidate.backend.c_str(), c.candidate.horizon,
                c.candidate.period_at(target.control_period), c.candidate.step_at(target.control_period),
                c.candidate.backend == "sa" ? std::to_string(c.candidate.knots).c_str() : "-",
                c.candidate.deadline_margin);
    int misses = 0;
    int once = 0;  // misses that did not recur when their run was repeated (not counted)
    for (std::size_t k = 0; k < scenarios.size(); ++k) {
      if (k < c.scenarios.size()) {
        const ScenarioScore& s = c.scenarios[k];
        misses += s.deadline_misses;
        once += s.unconfirmed_misses;
        std::printf("  %6.3f / %5.2f%-9s", s.wear_ratio,
                    s.target_period_baseline_rmse_m > 0.0 ? s.rmse_m / s.target_period_baseline_rmse_m : 0.0,
                    s.acceptable() ? "" : " (no)");
      } else {
        std::printf("  %-22s", "-");
      }
    }
    const bool own = static_cast<int>(i) == result.incumbent;
    std::printf(" %10.3f %8d %6d %14d%s%s%s\n", c.geomean_wear_ratio, misses, once, c.unacceptable,
                !own && no_worse_on_every_scenario(c, result.candidates[static_cast<std::size_t>(result.incumbent)])
                    ? "   >= own"
                    : "",
                static_cast<int>(i) == result.best ? "   <- best" : "",
                own ? "   (the controller file's own)" : "");
  }
  std::printf("per scenario: wear / position RMSE, each as a ratio to the kinematic baseline's at the target's "
              "period; (no): outside the bounds; "
              "once: misses that did not recur when their run was repeated (the machine's stalls; not counted); "
              ">= own: no more wear and no higher position RMSE than the controller file's own on every scenario\n");
  std::printf("rule: %s\n", QualityTuningResult::rule());
}

// The tuned file's header: how the candidate was chosen and what it scored.
std::string tuned_file_header(const CandidateScore& chosen, const std::string& how, const QualityTuningResult& result,
                              const TargetConfig& target, const TuneArguments& a) {
  std::ostringstream header;
  const double period = chosen.candidate.period_at(target.control_period);
  header << "# Tuned by `swerve-mpc tune` for target " << target.name << " (" << target.description
         << ") from " << a.controller_file << ":\n# backend " << describe(chosen.candidate) << ", control period "
         << period << " s, deadline margin " << chosen.candidate.deadline_margin << ", solve budget "
         << target.budget_at(period).value_or(target.solve_budget) << " s; geometric-mean wear "
         << chosen.geomean_wear_ratio << " of the kinematic baseline's (at " << target.control_period << " s) on";
  for (const ScenarioScore& s : chosen.scenarios) header << " " << s.scenario;
  if (!a.seeds.empty()) {
    header << " (medians over simulator seeds";
    for (const std::uint64_t seed : a.seeds) header << " " << seed;
    header << ")";
  }
  const CandidateScore& own = result.candidates[static_cast<std::size_t>(result.incumbent)];
  header << "\n# (the controller file's own " << describe(own.candidate) << ": " << own.geomean_wear_ratio
         << "), at " << target.cpu_slowdown << "x this machine's time.\n# Rule: " << how << ".\n";
  for (const ScenarioScore& s : chosen.scenarios) {
    if (s.acceptable()) continue;
    header << "# Outside the tracking bounds on " << s.scenario << ": position RMSE " << s.rmse_m << " m against "
           << s.baseline_rmse_m << " m, heading " << s.heading_rmse_rad << " rad against "
           << s.baseline_heading_rmse_rad << " rad (the baseline's), " << s.tracking_excess() << "x the bound.\n";
  }
  return header.str();
}

// No candidate met the rule: reports the closest, and writes it only with --accept-tracking-loss.
template <typename Write>
int report_closest(const QualityTuningResult& result, const TuneArguments& a, Write&& write) {
  std::printf(
      "no candidate kept the baseline's tracking without a deadline miss on every scenario: raise the "
      "budget, or try other backends, horizons and knots\n");
  if (result.closest < 0) {
    std::printf("and every candidate missed a deadline on some scenario: nothing fits the budget\n");
    return kExitFailure;
  }
  const CandidateScore& closest = result.candidates[static_cast<std::size_t>(result.closest)];
  const ScenarioScore* worst = &closest.scenarios.front();
  for (const ScenarioScore& s : closest.scenarios) {
    if (s.tracking_excess() > worst->tracking_excess()) worst = &s;
  }
  std::printf(
      "closest: %s, deadline margin %.2f (worst: %s at %.2fx its RMSE bound)\n"
      "closest rule: %s\n",
      describe(closest.candidate).c_str(), closest.candidate.deadline_margin, worst->scenario.c_str(),
      worst->tracking_excess(), QualityTuningResult::closest_rule());
  if (a.write_file.empty()) return kExitFailure;
  if (!a.accept_tracking_loss) {
    std::printf("not written: it does not keep the baseline's tracking; --accept-tracking-loss writes it\n");
    return kExitFailure;
  }
  write(closest, std::string(QualityTuningResult::closest_rule()) + " (no candidate met the rule: " +
                     QualityTuningResult::rule() + ")");
  return kExitOk;
}

int tune_by_quality_command(const TuneArguments& a) {
  const std::optional<WorkClock> work_clock = work_clock_for(a.work_clock);
  const QualityTuningOptions options = quality_options_of(a, work_clock ? &*work_clock : nullptr);
  try {
    options.validate();
  } catch (const ConfigError& error) {
    throw UsageError(std::string("tune: ") + error.what());
  }
  if (!a.write_file.empty()) check_write_file(a.write_file, a.force);
  if (!a.out_dir.empty()) {
    try {
      prepare_output_directory(a.out_dir);
    } catch (const std::runtime_error& error) {
      throw std::runtime_error(std::string("--out ") + error.what() + "; nothing was run");
    }
  }
  std::vector<ScenarioConfig> scenarios;
  for (const std::string& file : a.scenario_files) scenarios.push_back(load_scenario_config_file(file));
  const ControllerConfig controller = load_controller_config_file(a.controller_file);
  const TargetConfig target = load_target_config_file(a.target_file);
  try {
    (void)options.periods_tried(target);
  } catch (const ConfigError& error) {
    throw UsageError(std::string("tune: ") + error.what());
  }
  print_tuning_plan(controller, target, options, scenarios.size(), a);
  const bool bar = !a.quiet && isatty(STDERR_FILENO);
  const QualityTuningResult result =
      tune_by_quality(controller, target, scenarios, options, [bar](int done, int total, int round) {
        if (!bar) return;
        std::fprintf(stderr, "\r  round %d: %d/%d candidates", round, done, total);
        if (done == total) std::fprintf(stderr, "\n");
        std::fflush(stderr);
      });
  print_candidate_table(result, scenarios, target);
  if (!a.out_dir.empty()) {
    std::ofstream(a.out_dir + "/tune.json") << to_json(result, target).dump(2) << "\n";
    std::printf("written: %s/tune.json\n", a.out_dir.c_str());
  }
  const auto write = [&](const CandidateScore& chosen, const std::string& how) {
    write_tuned_controller(a.controller_file, chosen.candidate, target,
                           tuned_file_header(chosen, how, result, target, a), a.write_file);
    std::printf("written: %s\n", a.write_file.c_str());
  };
  if (result.best < 0) return report_closest(result, a, write);
  const CandidateScore& best = result.candidates[static_cast<std::size_t>(result.best)];
  std::printf(
      "best: %s (%.2f s of lookahead at %.0f ms), deadline margin %.2f: geometric-mean "
      "wear %.3f of the baseline's\n",
      describe(best.candidate).c_str(), best.candidate.horizon * best.candidate.step_at(target.control_period),
      1e3 * best.candidate.period_at(target.control_period), best.candidate.deadline_margin, best.geomean_wear_ratio);
  if (!a.write_file.empty()) write(best, QualityTuningResult::rule());
  return kExitOk;
}

int tune(const TuneArguments& a) {
  if (!a.scenario_files.empty()) return tune_by_quality_command(a);
  // The options come from the command line only: breaking their rules is a command-line error.
  try {
    a.options.validate();
  } catch (const ConfigError& error) {
    throw UsageError(std::string("tune: ") + error.what());
  }
  const VehicleParams vehicle = load_vehicle_config_file(a.vehicle_file);
  const ControllerConfig controller = load_controller_config_file(a.controller_file);
  const TargetConfig target = load_target_config_file(a.target_file);
  TuningOptions options = a.options;
  std::optional<WorkClock> work_clock = work_clock_for(a.work_clock);
  if (work_clock) options.clock = &*work_clock;
  const TuningResult result = tune_horizon(vehicle, controller, target, options);
  std::printf("tune: %s (%d modules), controller %s (%s), target %s: %.0f ms of every %.0f ms cycle, "
              "%.2fx this machine's time\n",
              vehicle.name.c_str(), vehicle.layout.size(), controller.name.c_str(), controller.solver.backend.c_str(),
              target.name.c_str(), 1e3 * target.solve_budget, 1e3 * target.control_period, target.cpu_slowdown);
  std::printf("%8s %14s %16s %14s %16s %10s %10s\n", "horizon", "lookahead [s]", "budget here [ms]",
              "proposals/solve", "p99 target [ms]", "fallbacks", "qualifies");
  for (const HorizonMeasurement& row : result.rows) {
    std::printf("%8d %14.2f %16.2f %14.0f %16.2f %10d %10s\n", row.horizon, row.lookahead_s, row.budget_here_ms,
                row.proposals_median, row.target_p99_ms, row.fallbacks, row.qualifies ? "yes" : "no");
  }
  if (result.recommended_horizon == 0) {
    std::printf("no horizon gets %d proposals per solve within the target's budget: lower min-proposals, raise the "
                "budget, or use fewer SA knots\n",
                a.options.min_proposals);
    return kExitFailure;
  }
  std::printf("recommended: horizon %d (%.2f s of lookahead at %.0f ms), set controller.horizon and dt\n",
              result.recommended_horizon, result.recommended_horizon * target.control_period,
              1e3 * target.control_period);
  return kExitOk;
}

}  // namespace

Command make_tune_command() {
  return {"tune", "Find the largest horizon the wear-aware controller can search well within a target's budget",
          [](CLI::App& app) -> std::function<int()> {
            auto a = std::make_shared<TuneArguments>();
            app.add_option("--vehicle", a->vehicle_file, "Vehicle YAML")->capture_default_str();
            app.add_option("--controller", a->controller_file, "wear_mpc controller YAML")->capture_default_str();
            app.add_option("--target", a->target_file, "Embedded target YAML")->capture_default_str();
            CLI::Option* horizons =
                app.add_option("--horizons", a->options.horizons,
                               "Candidate horizons, comma-separated [sizing 5,10,20,30,40; quality 10,15,20,30]")
                    ->delimiter(',');
            app.add_option("--scenarios", a->scenario_files,
                           "Scenario YAMLs (comma-separated, each with a kinematic_baseline): choose by closed-loop "
                           "quality on them")
                ->delimiter(',');
            app.add_option("--knots", a->knots, "Candidate SA knot counts (quality), comma-separated")
                ->delimiter(',')
                ->capture_default_str();
            app.add_option("--backends", a->backends,
                           "Candidate solver backends (quality; sa at every knot count, the others once per "
                           "horizon and margin), comma-separated [the controller file's own]")
                ->delimiter(',');
            app.add_option("--margins", a->margins,
                           "Candidate deadline margins (quality; share of the budget kept free), comma-separated "
                           "[the controller file's own]")
                ->delimiter(',');
            app.add_option("--dts", a->dts,
                           "Candidate prediction steps dt in s (quality; each at least the target's control "
                           "period: a longer one looks as far with fewer steps), comma-separated [the control "
                           "period]")
                ->delimiter(',');
            app.add_option("--periods", a->periods,
                           "Candidate control periods in s (quality; each the target's control_period or one of "
                           "its other_periods, at that period's budget), comma-separated [the target's]")
                ->delimiter(',');
            app.add_option("--seeds", a->seeds,
                           "Simulator seeds each candidate runs every scenario with (quality; medians over them), "
                           "comma-separated [each scenario's own]")
                ->delimiter(',');
            app.add_option("--write", a->write_file, "Write the best candidate's controller YAML here (quality)");
            app.add_flag(
                "--accept-tracking-loss", a->accept_tracking_loss,
                "With --write, when no candidate keeps the baseline's tracking: write the one closest to it "
                "that misses no deadline (quality)");
            app.add_flag("--force", a->force, "Let --write replace an existing file");
            app.add_option("--out", a->out_dir, "Write tune.json here (quality)");
            app.add_flag("-q,--quiet", a->quiet, "No progress bar");
            add_work_clock_option(app, &a->work_clock);
            app.add_option("--cycles", a->options.cycles, "Closed-loop cycles measured per horizon")
                ->capture_default_str();
            app.add_option("--min-proposals", a->options.min_proposals,
                           "Median optimiser proposals per solve a horizon needs")
                ->capture_default_str();
            return [a, horizons]() {
              a->horizons_given = horizons->count() > 0;
              return tune(*a);
            };
          }};
}

}  // namespace swerve::cli
