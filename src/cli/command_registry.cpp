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
      make_check_config_command(),
  };
  return commands;
}

void add_work_clock_option(CLI::App& app, double* seconds_per_read) {
  // Positive and at most a second (a larger cost would end every solve at its first read).
  static const CLI::Validator rule(
      [](std::string& text) -> std::string {
        double value = 0.0;
        const char* end = text.data() + text.size();
        const auto [stop, error] = std::from_chars(text.data(), end, value);
        if (!text.empty() && error == std::errc() && stop == end && value > 0.0 && value <= 1.0) return "";
        return "'" + printable_value(text) + "': must be a number of seconds in (0, 1]";
      },
      "SECONDS");
  app.add_option("--work-clock", *seconds_per_read,
                 "Keep deadlines on a clock that advances this many s per read instead of the wall clock: the "
                 "same work on every machine and under an emulator (repeatable runs, instruction counts)")
      ->check(rule);
}

std::optional<WorkClock> work_clock_for(double seconds_per_read) {
  if (seconds_per_read > 0.0) return WorkClock(seconds_per_read);
  return std::nullopt;
}

std::string work_clock_notice(double seconds_per_read) {
  char line[128];
  std::snprintf(line, sizeof line, "deadlines and timings are on a work clock (%g s per read), not the wall clock",
                seconds_per_read);
  return line;
}

}  // namespace swerve::cli
