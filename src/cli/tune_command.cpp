// `swerve-mpc tune`: sizes the wear-aware controller's horizon for an embedded target (see
// swerve/app/tuning.hpp) and prints one row per horizon and the largest one that qualifies.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>

#include "command_registry.hpp"
#include "swerve/app/vehicle_config.hpp"
#include "swerve/app/tuning.hpp"

namespace swerve::cli {
namespace {

struct TuneArguments {
  std::string vehicle_file = "configs/vehicles/paper_ms_agv.yaml";
  std::string controller_file = "configs/controllers/default.yaml";
  std::string target_file = "configs/targets/default.yaml";
  TuningOptions options;
};

int tune(const TuneArguments& a) {
  // The options come from the command line only: breaking their rules is a command-line error.
  try {
    a.options.validate();
  } catch (const ConfigError& error) {
    throw UsageError(std::string("tune: ") + error.what());
  }
  const VehicleParams vehicle = load_vehicle_config_file(a.vehicle_file);
  const ControllerConfig controller = load_controller_config_file(a.controller_file);
  const TargetConfig target = load_target_config_file(a.target_file);
  const TuningResult result = tune_horizon(vehicle, controller, target, a.options);
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
            app.add_option("--horizons", a->options.horizons, "Candidate horizons, comma-separated")
                ->delimiter(',')
                ->capture_default_str();
            app.add_option("--cycles", a->options.cycles, "Closed-loop cycles measured per horizon")
                ->capture_default_str();
            app.add_option("--min-proposals", a->options.min_proposals,
                           "Median optimiser proposals per solve a horizon needs")
                ->capture_default_str();
            return [a]() { return tune(*a); };
          }};
}

}  // namespace swerve::cli
