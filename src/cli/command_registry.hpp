// The one place where swerve-mpc's subcommands are registered: each command adds its options to
// its CLI11 subcommand and runs when selected, returning the process exit code.
#pragma once

#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "swerve/ocp/deadline.hpp"
#include "swerve/ocp/work_clock_rates.hpp"

namespace CLI {
class App;
}

namespace swerve::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // the command ran and found a problem (bad config, failed run)
inline constexpr int kExitUsage = 2;    // the command line itself is wrong

// Thrown by a command when its command line is wrong in a way only the command can see (an option
// value that does not fit the loaded scenario); main reports it with kExitUsage.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// --work-clock SECONDS (run, tune, bench-targets, envelope): keep the controllers' deadlines on a
// clock that advances this much per read instead of the wall clock, plus
// --work-clock-evaluation SECONDS per module evaluation the prediction model charges (default: the
// reference machine's, kReferenceSecondsPerModuleEvaluation; 0: reads only), so the same work is
// done on every machine. Rejects anything but a number in (0, 1] (the evaluation's: [0, 1]) as a
// command-line error.
void add_work_clock_option(CLI::App& app, WorkClockRates* rates);
// The clock those options ask for: a WorkClock from zero, or none without --work-clock (the steady
// clock). Each controller run gets its own, so every run starts from the same time.
std::optional<WorkClock> work_clock_for(const WorkClockRates& rates);
// The line a command prints when its deadlines and timings are on a work clock.
std::string work_clock_notice(const WorkClockRates& rates);

struct Command {
  std::string name;
  std::string summary;
  // Declares options on `app`; returns the action to run once parsing succeeded.
  std::function<std::function<int()>(CLI::App& app)> declare;
};

// Every subcommand, in the order --help lists them.
const std::vector<Command>& all_commands();

// Defined by each command's own file.
Command make_check_config_command();
Command make_config_reference_command();
Command make_run_command();
Command make_sweep_command();
Command make_tune_command();
Command make_bench_targets_command();
Command make_envelope_command();
Command make_merge_command();

}  // namespace swerve::cli
