// The operating envelope generator (`swerve-mpc envelope`): random cases, each a vehicle, a
// planner-like reference and run conditions drawn from a seed, written as ordinary scenario files,
// loaded back and run with the wear-aware controller and the kinematic baseline, then judged.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "swerve/app/shard.hpp"
#include "swerve/ocp/deadline.hpp"
#include "swerve/ocp/work_clock_rates.hpp"

#include "swerve/sim/metrics.hpp"

namespace swerve {

// The reference families a draw picks from. Built-in scenario types serve the ones they can
// express (line, arc, figure_eight and the line-with-offset families); the rest are written as a
// sampled CSV reference beside the scenario.
enum class ReferenceFamily {
  kLine,
  kArc,
  kSCurve,
  kLaneChange,
  kFigureEight,
  kHeadingOffset,  // a constant 0-90 deg offset while translating
  kHeadingChange,  // the heading turns while translating
  kCrab,           // 90 deg offset
  kReverse,        // driving backwards (180 deg offset)
  kCreepToStop,    // slows to a creep, then stops
  kStopAndGo,
  kTurnThenGo,     // a turn in place, a dwell, then a straight leg at the new heading (a crab at 90 deg)
};
const char* to_string(ReferenceFamily family) noexcept;  // "line", "s_curve", ...
const std::vector<ReferenceFamily>& all_reference_families();
std::optional<ReferenceFamily> reference_family_named(const std::string& name);
std::string reference_family_names();  // "line, arc, ..." for messages

struct EnvelopeOptions {
  int draws = 100;
  std::uint64_t seed = 1;
  int jobs = 1;                       // draws run in parallel threads, each run on its own clock
  std::vector<std::string> families;  // names (to_string); empty: every family
  std::string out_dir = "out/envelope";
  std::string controller_file = "configs/controllers/default.yaml";
  std::string baseline_file = "configs/controllers/kinematic_baseline.yaml";
  // s per clock read of each run's WorkClock; 0: the steady (wall) clock. The work clock is the
  // default so that the same seed gives the same verdicts on every machine and at every --jobs.
  double work_clock = kReferenceSecondsPerRead;
  // s per module evaluation the prediction model charges to that clock (0: reads only).
  double work_clock_evaluation = kReferenceSecondsPerModuleEvaluation;
  // The share of the draws this run does (index % count == shard.index); whole: all of them.
  Shard shard;

  // The families asked for, in the order given (every family when none is named). Call validate() first.
  std::vector<ReferenceFamily> family_list() const;
  void validate() const;  // throws ConfigError "EnvelopeOptions.<field> = <value>: <rule>"
};

// A drawn vehicle, in the terms of a vehicle YAML file (configs/vehicles/*.yaml).
struct VehicleDraw {
  std::string layout;                                    // "grid" (axles x 2 modules) or "triangle"
  int axles = 0;                                         // grid only
  std::vector<Eigen::Vector2d> module_positions;         // body frame, m
  double mass = 0.0;                                     // kg
  double footprint_length = 0.0, footprint_width = 0.0;  // m, the plate the yaw inertia is taken of
  double yaw_inertia = 0.0;                              // m (L^2 + W^2) / 12, kg m^2
  double wheel_radius = 0.0;
  double steering_limit = 0.0;  // rad: pi/2, or pi (unlimited)
  double mu = 0.0;
  double steering_time_constant = 0.0, drive_time_constant = 0.0;           // s
  double drive_speed = 0.0, drive_acceleration = 0.0, steering_rate = 0.0;  // m/s, m/s^2, rad/s
  int modules() const { return static_cast<int>(module_positions.size()); }
  double radius() const;  // m: the outermost module's distance from the centre
};

// A drawn reference: a built-in scenario type with its keys, or sampled rows for `type: csv`.
struct ReferenceDraw {
  std::string type;                         // line | arc | figure_eight | csv
  double direction = 0.0;                   // rad, the path's initial direction
  double length = 0.0;                      // line
  double radius = 0.0, sweep = 0.0;         // arc
  double size = 0.0;                        // figure_eight
  double speed = 0.0, acceleration = 0.0;   // m/s, m/s^2 (the trapezoid of the built-in types)
  double heading_offset = 0.0;              // rad
  std::vector<std::array<double, 7>> rows;  // csv: t, x, y, psi, vx, vy, r (body frame)
  double duration = 0.0;                    // s the reference moves
  std::string summary;                      // one line for reports
};

struct ConditionsDraw {
  double control_period = 0.05;  // s
  double solve_budget = 0.02;    // s: 0.4 x control_period
  int measurement_delay_steps = 0;
  double latency = 0.0;  // s: measurement_delay_steps x control_period
  bool noise = false;    // crab90_noisy.yaml's sensor noise, behind its observer
  int simulator_seed = 1;
};

struct Draw {
  std::uint64_t seed = 0;
  int index = 0;
  ReferenceFamily family = ReferenceFamily::kLine;
  VehicleDraw vehicle;
  ReferenceDraw reference;
  ConditionsDraw conditions;
  double duration = 0.0;  // s of the run (the reference's by default)
};

// Draw `index` of `seed`: the same arguments give the same draw, bit for bit, whatever else was
// drawn before. The family is families[index % families.size()], so every family is covered once
// the count reaches the list's size; everything else is random. Throws ConfigError for an empty list.
Draw draw_case(std::uint64_t seed, int index, const std::vector<ReferenceFamily>& families);

// File texts of a draw. The controller texts are copies of the given controller files' texts with
// the draw's control period (and, for the wear-aware controller, a solve budget of 0.4 x period)
// set; the baseline runs at dt = control period, as `swerve-mpc tune` runs it at a target's period.
std::string vehicle_yaml(const Draw& draw);
std::string scenario_yaml(
    const Draw& draw);  // names vehicle.yaml, reference.csv, wear_mpc.yaml, kinematic_baseline.yaml
std::string reference_csv(const Draw& draw);  // "" unless reference.type is csv
std::string controller_yaml(const std::string& source_text, const std::string& source_name, const Draw& draw);
std::string baseline_yaml(const std::string& source_text, const std::string& source_name, const Draw& draw);

// Writes the draw's files into `dir` (created) and returns the scenario file's path. The controller
// files' texts are read from options.controller_file and options.baseline_file.
std::string write_draw(const Draw& draw, const std::string& dir, const EnvelopeOptions& options);

// One controller's run on a draw.
struct EnvelopeRun {
  bool ran = false;        // a run happened and produced metrics
  bool completed = false;  // the plant did not diverge
  std::string failure;
  RunMetrics metrics;
  int safe_stops = 0;  // periods whose command came from CommandSource::kSafeStop
};

// The goals of one draw: the wear-aware run against the baseline's.
struct EnvelopeGoals {
  bool ran = false;              // both runs happened and completed (false: no goal holds)
  bool wear = false;             // wear_total <= the baseline's
  bool position = false;         // tracking RMSE <= max(1.1x, +0.02 m)
  bool heading = false;          // heading RMS <= max(1.1x, +0.5 deg)
  bool steering_effort = false;  // <= max(1.5x, +0.5 rad^2/s)
  bool deadlines = false;        // zero deadline misses
  bool no_safe_stop = false;
  bool gross =
      false;  // wear > 2x the baseline's or RMSE > the baseline's + 5 cm (runs that produced metrics)
  double wear_ratio = 0.0;  // NaN when not both ran; +inf over a zero baseline
  double steering_effort_ratio = 0.0;
  double rmse_excess_m = 0.0;  // wear_mpc's RMSE minus the baseline's
  bool all() const {
    return ran && wear && position && heading && steering_effort && deadlines && no_safe_stop;
  }
};
EnvelopeGoals evaluate_goals(const EnvelopeRun& wear_mpc, const EnvelopeRun& baseline);

int count_safe_stops(const std::vector<StepRecord>& log);

struct DrawResult {
  Draw draw;
  std::string scenario_file;
  std::string error;  // why the draw could not be written, loaded or run ("" when it ran)
  EnvelopeRun wear_mpc, baseline;
  EnvelopeGoals goals;
};

// Writes the draw into `dir`, loads the scenario back through load_scenario_config_file, and runs
// both controllers, each on its own clock (options.work_clock). Never throws for a draw that fails:
// the failure is kept in `error` and the draw does not meet its goals.
DrawResult run_draw(const Draw& draw, const std::string& dir, const EnvelopeOptions& options);

struct EnvelopeResult {
  EnvelopeOptions options;
  std::vector<DrawResult> draws;  // by index (a shard's: its own draws, in index order)
  int met = 0;                    // draws meeting every goal
  int gross = 0;
  int failed = 0;  // draws that could not be written, loaded or run to the end
  double rate() const {
    return draws.empty() ? 0.0 : static_cast<double>(met) / static_cast<double>(draws.size());
  }
};

// A draw whose drawing itself threw (`why`): reported, never dropped, meeting no goal.
DrawResult undrawn_result(std::uint64_t seed, int index, const std::vector<ReferenceFamily>& families,
                          const std::string& dir, const std::string& why);
// Sets met, gross and failed from the draws' goals.
void count_goals(EnvelopeResult* result);

// Called once a draw is done (under a lock: one call at a time), with the number done so far.
using EnvelopeCallback = std::function<void(const DrawResult&, int done, int total)>;

// Validates the options, draws every case (of options.shard's share) and runs them on options.jobs
// threads; each draw in <out_dir>/draws/<index>/. Throws ConfigError for bad options or controller
// files that cannot be read.
EnvelopeResult run_envelope(const EnvelopeOptions& options, const EnvelopeCallback& on_done = {});

// The printed report: rate, ratio distributions, gross count, the ten worst draws.
std::string envelope_report(const EnvelopeResult& result);
// <out_dir>/envelope.json's text; write_envelope_json writes it there (std::runtime_error on failure).
std::string envelope_json(const EnvelopeResult& result);
void write_envelope_json(const EnvelopeResult& result, const std::string& path);

// A shard's record (<out_dir>/shard.json): the options and every draw's runs, losslessly (every
// metric as written bit for bit, non-finite values included), for merge_envelope_shards.
void write_envelope_shard(const EnvelopeResult& result, const std::string& path);
// The whole envelope from the folders of shards 0..N-1 of one run (any order): their draw folders
// copied into <out_dir>/draws/, and the result one unsharded run with out_dir would have given, so
// that envelope_json and envelope_report of it are that run's byte for byte. Throws ConfigError
// naming the folder for a missing or unreadable shard.json, a shard given twice or missing, shards
// of different runs (seed, draws, families, controller files, clock) or a shard without its draws.
EnvelopeResult merge_envelope_shards(const std::vector<std::string>& shard_dirs, const std::string& out_dir);

}  // namespace swerve
