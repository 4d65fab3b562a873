// Tuning the wear-aware controller for an embedded target, in two parts. Sizing (tune_horizon):
// per candidate horizon, how many optimiser proposals fit in a solve at the target's budget
// translated to this machine (budget / cpu_slowdown); SA always spends its whole budget, so solve
// time alone says nothing. Quality (tune_by_quality): candidates (backend, horizon, SA knots,
// deadline margin) run the given scenarios in closed loop at that budget against the kinematic
// baseline, and the winner is the least wear that keeps the baseline's tracking and misses no
// deadline, a candidate no worse than the controller file's own on every scenario first.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "swerve/app/controller_config.hpp"
#include "swerve/app/scenario_config.hpp"
#include "swerve/app/target_config.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/ocp/deadline.hpp"

namespace swerve {

struct TuningOptions {
  std::vector<int> horizons{5, 10, 20, 30, 40};
  int cycles = 20;          // closed-loop periods measured per horizon
  int min_proposals = 50;   // median optimiser proposals per solve a horizon needs to qualify
  const Clock* clock = nullptr;  // the controllers' clock (nullptr: the steady clock; tests inject one)
  void validate() const;    // ConfigError naming the field and value
};

struct HorizonMeasurement {
  int horizon = 0;
  double lookahead_s = 0.0;            // horizon x control period
  double budget_here_ms = 0.0;         // target budget / cpu_slowdown
  double proposals_median = 0.0;       // per solve
  double solve_p99_ms = 0.0;           // on this machine
  double target_p99_ms = 0.0;          // solve_p99_ms x cpu_slowdown
  int fallbacks = 0;
  bool qualifies = false;              // enough proposals and no fallback (a late solve is one)
};

struct TuningResult {
  std::vector<HorizonMeasurement> rows;
  int recommended_horizon = 0;  // the largest qualifying horizon; 0 when none qualifies
};

// `controller` must be a wear_mpc config; its dt and solve budget are replaced by the target's.
// The closed loop follows a straight line at half the drive speed limit, starting on it at that speed.
TuningResult tune_horizon(const VehicleParams& vehicle, const ControllerConfig& controller, const TargetConfig& target,
                          const TuningOptions& options);

// --- Tuning by closed-loop quality ---

struct TuningCandidate {
  int horizon = 20;              // prediction steps of dt
  int knots = 3;                 // SA move-blocking knots (backend sa); 0 for the other backends
  double deadline_margin = 0.15; // share of the budget kept free for the OS and the step's own variation
  std::string backend = "sa";    // controller.solver.backend
  double dt = 0.0;               // s, the prediction's step: the candidate's control period or longer; 0: the period
  // s, the loop's period: the target's control_period or one of its other_periods; 0: the target's.
  double control_period = 0.0;
  double period_at(double target_period) const noexcept { return control_period > 0.0 ? control_period : target_period; }
  double step_at(double target_period) const noexcept { return dt > 0.0 ? dt : period_at(target_period); }
};

struct QualityTuningOptions {
  std::vector<int> horizons{10, 15, 20, 30};
  std::vector<int> knots{3, 6};           // for the sa backend
  // Prediction steps dt (s), each at least the target's control period (a longer one looks as far
  // with fewer steps; ControllerOptions::control_period); empty: the control period only.
  std::vector<double> dts;
  // Control periods (s), each the target's control_period or one of its other_periods (where the
  // target allows a choice of loop rate), each at that period's budget; empty: the target's own.
  // A dt shorter than a period is not tried at that period.
  std::vector<double> periods;
  std::vector<double> deadline_margins;  // empty: the controller's own only
  // Backends to try, each a built one (built_backends()); empty: the controller's own only. The
  // sa backend is tried at every knot count, the others once per horizon and margin.
  std::vector<std::string> backends;
  std::vector<std::uint64_t> seeds;      // simulator seeds per scenario (medians over them); empty: the scenario's
  const Clock* clock = nullptr;  // the controllers' clock (nullptr: the steady clock; tests inject one)
  void validate() const;         // ConfigError naming the field and value
  // validate(), then against the target tuned for: every period one it allows, and every dt at
  // least the shortest period tried (a cycle must not skip a prediction step). Returns the periods
  // tried, the target's own first (every wear ratio is against its baseline).
  std::vector<double> periods_tried(const TargetConfig& target) const;
};

// One candidate on one scenario, against the scenario's kinematic baseline at the same seeds:
// medians over the seeds, misses and fallbacks summed. The baseline runs at the target's control
// period and, for a candidate at another of the target's periods, at that one too: the wear ratio
// is against the former (one yardstick for every candidate, so ratios rank like absolute wear),
// the tracking against the better-tracking of the two (a faster loop must not lower the bar).
struct ScenarioScore {
  std::string scenario;
  double wear_ratio = 0.0;                 // wear / the baseline's at the target's control period
  double rmse_m = 0.0, baseline_rmse_m = 0.0;  // baseline: the bounds' (the better-tracking one)
  double heading_rmse_rad = 0.0, baseline_heading_rmse_rad = 0.0;
  // The baseline's position RMSE at the target's control period: the one yardstick for every
  // candidate's RMSE ratio in a table, as for wear (equal to baseline_rmse_m at that period).
  double target_period_baseline_rmse_m = 0.0;
  double step_p99_ms = 0.0;                // on this machine, the largest over the seeds
  // Misses that recurred: a run with a miss is run again (same seed), and the fewer of the two runs'
  // miss counts is counted (a count, not matched step by step; the first run's other figures are
  // kept). The operating system's scheduling stalls (up to ~6 ms on a shared machine) miss at
  // random and seldom in both runs; a candidate too slow for its budget misses in both.
  int deadline_misses = 0, fallbacks = 0;
  int unconfirmed_misses = 0;              // misses of a first run that its repeat did not have
  bool completed = false;
  // The bounds of "no worse tracking than the baseline": position RMSE <= max(1.1 b, b + 0.02 m),
  // heading RMSE <= max(1.1 b, b + 0.5 deg), no deadline miss, the run completed.
  bool acceptable() const;
  // How far outside those tracking bounds: the larger of position RMSE / its bound and heading
  // RMSE / its bound (<= 1: within both).
  double tracking_excess() const;
};

struct CandidateScore {
  TuningCandidate candidate;
  std::vector<ScenarioScore> scenarios;  // those it ran (all of them if it reached the last round)
  double geomean_wear_ratio = 0.0;       // over `scenarios`
  int unacceptable = 0;                  // scenarios failing ScenarioScore::acceptable()
  bool finalist = false;                 // ran every scenario (round 2 or 3)
};

struct QualityTuningResult {
  double budget_here_s = 0.0;            // the target's budget / cpu_slowdown, at its control_period
  std::vector<CandidateScore> candidates;
  int best = -1;                         // best_candidate(); -1 when no finalist is acceptable everywhere
  int incumbent = -1;                    // the controller's own horizon and knots (always a finalist)
  // Only when best < 0: closest_candidate(), the candidate that misses no deadline and tracks
  // closest to the bounds (the tracking-first choice for a target too slow for the bounds); -1
  // when best >= 0 or when every candidate missed a deadline somewhere.
  int closest = -1;
  static const char* rule();             // the selection rule, as printed
  static const char* closest_rule();     // closest's rule, as printed
};

// Whether `candidate` is at least as good as `own` on every scenario `own` ran: no higher wear ratio
// and no higher position RMSE on each (medians; the two must have run the same scenarios, in
// order): a tuned file should be no worse than the hand-set one anywhere.
bool no_worse_on_every_scenario(const CandidateScore& candidate, const CandidateScore& own);

// The rule's order over the scenarios each candidate ran (indices into `candidates`): fewest
// scenarios outside the bounds, then those no worse than the incumbent on every scenario
// (no_worse_on_every_scenario; the incumbent itself does not count), then the least geometric-mean
// wear; ties keep their order. Round 1 halves by it, on the first scenario.
std::vector<int> rank_candidates(const std::vector<CandidateScore>& candidates, int incumbent);

// QualityTuningResult::rule(): the first of rank_candidates() that is a finalist acceptable on
// every scenario; -1 if none is.
int best_candidate(const std::vector<CandidateScore>& candidates, int incumbent);

// Among the candidates that ran all `scenario_count` scenarios, each to the end without a deadline
// miss: the one whose worst scenario is least outside the tracking bounds
// (ScenarioScore::tracking_excess), ties broken by the least geometric-mean wear. -1 if none.
int closest_candidate(const std::vector<CandidateScore>& candidates, std::size_t scenario_count);

// (candidates done, candidates in this round, round) after each candidate's round.
using TuningProgress = std::function<void(int, int, int)>;

// The candidates tune_by_quality runs for a target whose `control_period` is given, in its order:
// per backend (the options' or the controller's own), period (the options'; the target's own
// carried as 0), dt (the options' at least that period, or the period), horizon, knot count (the sa
// backend's alone; the others carry 0, once) and margin, without repeats, and the controller's own
// setting (`incumbent`: its index, appended unless present; at the target's period, its dt that
// period, or its own dt when its file steps its prediction longer than its period).
struct QualityCandidates {
  std::vector<TuningCandidate> candidates;
  int incumbent = -1;
};
QualityCandidates quality_candidates(const ControllerConfig& controller, const QualityTuningOptions& options,
                                     double control_period);

// Every scenario needs a kinematic_baseline controller; `controller` is the wear_mpc config whose
// backend, control period (the target's or, with options.periods, another it allows), step,
// budget (that period's, translated), SA knots and deadline margin are varied; its own backend,
// horizon, knots and margin at the target's period are a candidate too (the incumbent). Round 1
// runs every candidate on the first scenario; round 2 runs the better half (rank_candidates) and
// the incumbent on all; only if none of those is acceptable everywhere,
// round 3 runs the rest on all, in round 1's order, until one is. The winner: best_candidate().
QualityTuningResult tune_by_quality(const ControllerConfig& controller, const TargetConfig& target,
                                    const std::vector<ScenarioConfig>& scenarios, const QualityTuningOptions& options,
                                    const TuningProgress& progress = {});

// Writes `base_file` (a controller YAML) with the candidate's backend, horizon, dt, control period
// (written only when it differs from dt), that period's solve budget (the target's), SA knots
// (backend sa) and deadline margin to `path`,
// headed by `header` (comment lines),
// and loads it back to check it. Throws ConfigError / std::runtime_error naming the file.
void write_tuned_controller(const std::string& base_file, const TuningCandidate& candidate, const TargetConfig& target,
                            const std::string& header, const std::string& path);

// --- The real-time report per target (`swerve-mpc bench-targets`) ---

// One controller config on one scenario at a target's period and translated budget; times are the
// target's (this machine's x cpu_slowdown).
struct RealTimeRow {
  std::string scenario;
  double period_ms = 0.0;                  // the control period it ran at
  double budget_ms = 0.0;                  // the target's solve budget at that period
  double step_p50_ms = 0.0, step_p99_ms = 0.0, step_max_ms = 0.0;
  double proposals_median = 0.0;           // optimiser proposals (SA) or iterations per solve
  // As the tuner counts them (ScenarioScore): a run with a miss is run again, and the fewer of the
  // two runs' misses count (the first run's times are kept); the rest are unconfirmed_misses, the
  // machine's scheduling stalls, which seldom strike twice where a controller too slow misses
  // every time.
  int deadline_misses = 0, fallbacks = 0;
  int unconfirmed_misses = 0;
  bool completed = false;
  bool passes() const;                     // completed, p99 step <= budget, no deadline miss
};

// Runs `controller` (a wear_mpc config) on each scenario with the target's budget translated to
// this machine (`clock`: as in tune_by_quality), again when it missed a deadline (RealTimeRow):
// at the controller's own period when the target
// allows it (one of TargetConfig::periods(), at that period's budget), else at the target's
// control period, the prediction step in the same ratio to it as in the file.
std::vector<RealTimeRow> measure_real_time(const ControllerConfig& controller, const TargetConfig& target,
                                           const std::vector<ScenarioConfig>& scenarios, const Clock* clock = nullptr);

}  // namespace swerve
