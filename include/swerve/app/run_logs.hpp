// A run's per-step logs in the formats robotics tools open, beside the CSV: WPILib's DataLog
// (`.wpilog`, for AdvantageScope, with WPILib's struct layouts so its swerve and field views read the
// poses and module states) and MCAP with JSON-schema channels (for Foxglove). One file holds every
// controller of the run, each under its own name.
#pragma once

#include <string>
#include <vector>

#include "swerve/app/scenario_runner.hpp"

namespace swerve {

// Which logs a run writes (`--log csv,wpilog,mcap`).
struct LogFormats {
  bool csv = true;
  bool wpilog = false;
  bool mcap = false;
};
// "csv,wpilog,mcap" in any order and subset (at least one); ConfigError naming the unknown word.
LogFormats parse_log_formats(const std::string& text);

// What the writers need besides the runs.
struct LogContext {
  std::string scenario;       // the scenario's name (the file's header says it)
  double wheel_radius = 0.0;  // m: wheel speeds (rad/s) become module speeds (m/s)
};

// WPILib DataLog 1.0 (wpilibc's datalog.adoc): per controller C, entries under /SwerveMPC/C/:
//   Pose, ReferencePose            struct:Pose2d (x, y m; rotation rad), the plant's and the reference's
//   ModuleStates/Measured          struct:SwerveModuleState[] (speed m/s, angle rad), the plant's
//   ModuleStates/Commanded         struct:SwerveModuleState[], what the controller sent
//   WearPerModule                  double[], cumulative wear per module
//   PositionError                  double, m
//   SolveTimeMs                    double, only at steps where a solve ran
//   CommandSource, SolveStatus     string
// with the structs' schemas under /.schema/. Timestamps in microseconds of the run's time. Throws
// std::runtime_error naming the path when it cannot be written.
void write_wpilog(const LogContext& context, const std::vector<ControllerRun>& runs, const std::string& path);

// MCAP (mcap.dev, version 0), unchunked and without a summary section (readers read it in order),
// JSON messages with JSON-schema schemas. Per controller C, topics:
//   /C/pose, /C/reference   foxglove.PoseInFrame (frame "world"), shown by Foxglove's 3D panel
//   /C/module_states        swervempc.ModuleStates {measured, commanded: [{speed, angle}]}
//   /C/wear                 swervempc.Wear {per_module, total}
//   /C/solver               swervempc.SolverStatus {source, status, solve_time_ms (null: no
//                           solve), iterations, position_error_m}
// log and publish times in nanoseconds of the run's time. Throws as write_wpilog.
void write_mcap(const LogContext& context, const std::vector<ControllerRun>& runs, const std::string& path);

}  // namespace swerve
