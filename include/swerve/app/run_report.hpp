// What a scenario run leaves behind: one per-step CSV log per controller and summary.json, the
// machine-readable contract (keys documented in docs/cli.md), written last and atomically so a
// partial run never looks complete; plus the comparison table printed on the terminal.
#pragma once

#include <string>
#include <vector>

#include "swerve/app/run_logs.hpp"
#include "swerve/app/scenario_runner.hpp"

namespace swerve {

// Wear change of `controller` against `reference` as a reduction in percent:
// 100 (W_ref - W_ctrl) / W_ref (docs/paper.md, assumption 12, with the sign flipped, so the paper's
// "-19.19 % wear" reads as a 19.19 % reduction). NaN when W_ref is 0.
double wear_reduction_pct(const RunMetrics& controller, const RunMetrics& reference);

// summary.json as text (2-space indented).
std::string summary_json(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs,
                         const LogFormats& formats = LogFormats{});

// Creates out_dir and proves it writable by creating and removing a probe file, so that a bad
// output directory is reported before a run rather than after it. Throws std::runtime_error
// naming the path that failed.
void prepare_output_directory(const std::string& out_dir);

// Writes the logs `formats` asks for (<out_dir>/<controller>.csv for each run; run.wpilog and
// run.mcap with every run, app/run_logs.hpp), then <out_dir>/summary.json (through a temporary
// file and a rename). Creates out_dir. Throws std::runtime_error naming the path that failed.
void write_run_outputs(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs,
                       const std::string& out_dir, const LogFormats& formats = LogFormats{});

// The terminal table: one row per controller (tracking RMSE/max, heading RMSE, wear total, wear
// reduction against the baseline, solve p99, misses, fallbacks), then the paper's figure if any.
std::string comparison_table(const ScenarioConfig& scenario, const std::vector<ControllerRun>& runs);

}  // namespace swerve
