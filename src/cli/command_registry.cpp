#include "command_registry.hpp"

#include <CLI/CLI.hpp>

#include <charconv>
#include <cstdio>

#include "swerve/core/error_text.hpp"

namespace swerve::cli {

const std::vector<Command>& all_commands() {
  static const std::vector<Command> commands = {
      make_run_command(),
      make_sweep_command(),
      make_tune_command(),
      make_bench_targets_command(),
      make_envelope_command(),
      make_merge_command(),
      make_check_config_command(),
      make_config_reference_command(),
  };
  return commands;
}

void add_work_clock_option(CLI::App& app, WorkClockRates* rates) {
  // At most a second (a larger cost would end every solve at its first read); a read costs > 0.
  const auto seconds_rule = [](bool zero_allowed) {
    return CLI::Validator(
        [zero_allowed](std::string& text) -> std::string {
          double value = 0.0;
          const char* end = text.data() + text.size();
          const auto [stop, error] = std::from_chars(text.data(), end, value);
          if (!text.empty() && error == std::errc() && stop == end && (value > 0.0 || (zero_allowed && value == 0.0)) &&
              value <= 1.0) {
            return "";
          }
          return "'" + printable_value(text) + "': must be a number of seconds in " + (zero_allowed ? "[0, 1]" : "(0, 1]");
        },
        "SECONDS");
  };
  app.add_option("--work-clock", rates->per_read_s,
                 "Keep deadlines on a clock that advances this many s per read (and --work-clock-evaluation per "
                 "module evaluation) instead of the wall clock: the same work on every machine and under an "
                 "emulator (repeatable runs, instruction counts)")
      ->check(seconds_rule(false));
  app.add_option("--work-clock-evaluation", rates->per_module_evaluation_s,
                 "With --work-clock: s the clock advances per module evaluation of the prediction model, so a "
                 "proposal costs by the vehicle's size as on the wall clock (0: reads only)")
      ->check(seconds_rule(true))
      ->capture_default_str();
}

std::optional<WorkClock> work_clock_for(const WorkClockRates& rates) {
  if (rates.per_read_s > 0.0) return WorkClock(rates.per_read_s, rates.per_module_evaluation_s);
  return std::nullopt;
}

std::string work_clock_notice(const WorkClockRates& rates) {
  char line[160];
  std::snprintf(line, sizeof line,
                "deadlines and timings are on a work clock (%g s per read, %g s per module evaluation), not the wall "
                "clock",
                rates.per_read_s, rates.per_module_evaluation_s);
  return line;
}

}  // namespace swerve::cli
