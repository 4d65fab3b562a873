#include "swerve/app/tuning.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "swerve/app/scenario_runner.hpp"
#include "swerve/core/constants.hpp"
#include "swerve/solvers/solver_factory.hpp"
#include "tuning_runs.hpp"

namespace swerve {
namespace {

// Each of `values` in [1, upper], else ConfigError naming `owner`.`field`[].
void require_each_in_range(const char* owner, const std::string& field, const std::vector<int>& values, int upper) {
  if (values.empty()) throw ConfigError(std::string(owner) + "." + field + ": empty: give at least one");
  for (const int value : values) {
    if (value < 1 || value > upper) {
      throw_invalid_field(owner, field + "[]", value, "must be in [1, " + std::to_string(upper) + "]");
    }
  }
}

}  // namespace

void TuningOptions::validate() const {
  require_each_in_range("TuningOptions", "horizons", horizons, kMaxHorizon);
  if (cycles < 1 || cycles > kMaxScenarioSteps) {
    throw_invalid_field("TuningOptions", "cycles", cycles, "must be in [1, " + std::to_string(kMaxScenarioSteps) + "]");
  }
  if (min_proposals < 1) throw_invalid_field("TuningOptions", "min_proposals", min_proposals, "must be >= 1");
}

TuningResult tune_horizon(const VehicleParams& vehicle, const ControllerConfig& controller, const TargetConfig& target,
                          const TuningOptions& options) {
  options.validate();
  target.validate();
  require_wear_mpc(controller, "tune");
  // One scenario per horizon: on a straight line at half the drive speed limit, already moving at
  // that speed (the common case), run through the same closed loop as `swerve-mpc run`.
  SpeedProfile profile;
  profile.speed = 0.5 * vehicle.layout.limits().max_drive_speed;
  ScenarioConfig scenario(vehicle);
  scenario.name = "tune";
  scenario.reference = std::make_shared<PathReference>(make_line_curve({0.0, 0.0}, 0.0, 1000.0), profile, 0.0);
  scenario.duration = options.cycles * target.control_period;
  scenario.initial_state = Eigen::VectorXd::Zero(6 + vehicle.layout.size());
  scenario.initial_state[StateIndex::kVx] = profile.speed;
  scenario.simulator.control_period = target.control_period;
  const double budget_here = target.solve_budget / target.cpu_slowdown;

  TuningResult result;
  for (const int horizon : options.horizons) {
    ScenarioController entry{controller.name, "", controller};
    entry.config.mpc.horizon = entry.config.baseline.horizon = horizon;
    entry.config.mpc.dt = entry.config.baseline.dt = target.control_period;
    entry.config.mpc.solve_budget = budget_here;
    const ControllerRun run = run_controller(scenario, entry, {}, 0, options.clock);
    std::vector<double> proposals;
    for (const StepRecord& record : run.log) {
      if (record.solve_time_s >= 0.0) proposals.push_back(std::max(0, record.solve_iterations));
    }
    HorizonMeasurement row;
    row.horizon = horizon;
    row.lookahead_s = horizon * target.control_period;
    row.budget_here_ms = 1e3 * budget_here;
    row.proposals_median = percentile(proposals, 50.0);
    row.solve_p99_ms = run.metrics.solve_time_p99_ms;
    row.target_p99_ms = row.solve_p99_ms * target.cpu_slowdown;
    row.fallbacks = run.metrics.fallbacks;
    // A late solve is a fallback (the controller's own rule), so "no fallback" covers the deadline.
    row.qualifies = run.completed && row.proposals_median >= options.min_proposals && row.fallbacks == 0;
    if (row.qualifies) result.recommended_horizon = std::max(result.recommended_horizon, horizon);
    result.rows.push_back(row);
  }
  return result;
}

void QualityTuningOptions::validate() const {
  require_each_in_range("QualityTuningOptions", "horizons", horizons, kMaxHorizon);
  require_each_in_range("QualityTuningOptions", "knots", knots, kMaxHorizon);
  if (seeds.size() > 100) throw_invalid_field("QualityTuningOptions", "seeds.size()", seeds.size(), "must be <= 100");
  const std::vector<std::string>& built = built_backends();
  for (const std::string& backend : backends) {
    if (std::find(built.begin(), built.end(), backend) == built.end()) {
      throw ConfigError("QualityTuningOptions: backends[] = '" + backend + "': not a backend of this build (built: " +
                        built_backends_text() + ")");
    }
  }
  // The controller's own rule for deadline_margin, from its table.
  Bound margin_rule;
  for (const OptionField<ControllerOptions>& field : ControllerOptions::timing_fields()) {
    if (std::string(field.name) == "deadline_margin") margin_rule = field.bound;
  }
  for (const double m : deadline_margins) {
    if (!std::isfinite(m) || !margin_rule.contains(m)) {
      throw_invalid_field("QualityTuningOptions", "deadline_margins[]", m, margin_rule.describe());
    }
  }
  for (const double dt : dts) {
    if (!(dt > 0.0 && dt <= 1.0)) throw_invalid_field("QualityTuningOptions", "dts[]", dt, "must be in (0, 1] s");
  }
  for (const double period : periods) {
    if (!(period > 0.0 && period <= 1.0)) {
      throw_invalid_field("QualityTuningOptions", "periods[]", period, "must be in (0, 1] s");
    }
  }
}

namespace {

// The tracking bounds (no worse than the baseline): max(1.1x, + 0.02 m) and max(1.1x, + 0.5 deg) of
// the baseline's.
double position_bound(const ScenarioScore& s) {
  return std::max(1.1 * s.baseline_rmse_m, s.baseline_rmse_m + 0.02);
}
double heading_bound(const ScenarioScore& s) {
  constexpr double kHalfDegree = 0.5 * kPi / 180.0;
  return std::max(1.1 * s.baseline_heading_rmse_rad, s.baseline_heading_rmse_rad + kHalfDegree);
}

}  // namespace

bool ScenarioScore::acceptable() const {
  return completed && deadline_misses == 0 && rmse_m <= position_bound(*this) &&
         heading_rmse_rad <= heading_bound(*this);
}

double ScenarioScore::tracking_excess() const {
  return std::max(rmse_m / position_bound(*this), heading_rmse_rad / heading_bound(*this));
}

const char* QualityTuningResult::rule() {
  return "the least geometric-mean wear ratio among candidates that ran every scenario with position and heading "
         "RMSE within max(1.1x, +0.02 m / +0.5 deg) of the baseline's and no deadline miss (a run with a miss is "
         "repeated; a miss counts when the repeat misses too), those at least as good as the controller file's own "
         "setting on every scenario (no more wear, no higher position RMSE) first";
}

bool no_worse_on_every_scenario(const CandidateScore& candidate, const CandidateScore& own) {
  if (candidate.scenarios.size() != own.scenarios.size() || own.scenarios.empty()) return false;
  for (std::size_t i = 0; i < own.scenarios.size(); ++i) {
    const ScenarioScore& c = candidate.scenarios[i];
    const ScenarioScore& o = own.scenarios[i];
    if (c.scenario != o.scenario || c.wear_ratio > o.wear_ratio || c.rmse_m > o.rmse_m) return false;
  }
  return true;
}

std::vector<int> rank_candidates(const std::vector<CandidateScore>& candidates, int incumbent) {
  const CandidateScore* own = incumbent >= 0 && static_cast<std::size_t>(incumbent) < candidates.size()
                                  ? &candidates[static_cast<std::size_t>(incumbent)]
                                  : nullptr;
  const auto ahead_of_own = [&](int i) {
    return own != nullptr && i != incumbent && no_worse_on_every_scenario(candidates[static_cast<std::size_t>(i)], *own);
  };
  std::vector<int> order(candidates.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    const CandidateScore& x = candidates[static_cast<std::size_t>(a)];
    const CandidateScore& y = candidates[static_cast<std::size_t>(b)];
    if (x.unacceptable != y.unacceptable) return x.unacceptable < y.unacceptable;
    const bool x_ahead = ahead_of_own(a);
    if (x_ahead != ahead_of_own(b)) return x_ahead;
    return x.geomean_wear_ratio < y.geomean_wear_ratio;
  });
  return order;
}

int best_candidate(const std::vector<CandidateScore>& candidates, int incumbent) {
  for (const int i : rank_candidates(candidates, incumbent)) {
    const CandidateScore& score = candidates[static_cast<std::size_t>(i)];
    if (score.finalist && score.unacceptable == 0) return i;
  }
  return -1;
}

const char* QualityTuningResult::closest_rule() {
  return "among candidates that ran every scenario without a deadline miss, the one whose worst scenario is "
         "least "
         "outside those RMSE bounds, then the least geometric-mean wear ratio";
}

int closest_candidate(const std::vector<CandidateScore>& candidates, std::size_t scenario_count) {
  int closest = -1;
  double closest_excess = 0.0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const CandidateScore& c = candidates[i];
    if (scenario_count == 0 || c.scenarios.size() != scenario_count) continue;
    double worst = 0.0;
    bool real_time = true;
    for (const ScenarioScore& s : c.scenarios) {
      real_time = real_time && s.completed && s.deadline_misses == 0;
      worst = std::max(worst, s.tracking_excess());
    }
    if (!real_time || !std::isfinite(worst)) continue;
    const bool better_choice =
        closest < 0 || worst < closest_excess ||
        (worst == closest_excess &&
         c.geomean_wear_ratio < candidates[static_cast<std::size_t>(closest)].geomean_wear_ratio);
    if (better_choice) {
      closest = static_cast<int>(i);
      closest_excess = worst;
    }
  }
  return closest;
}

namespace {

const ScenarioController& baseline_of(const ScenarioConfig& scenario) {
  for (const ScenarioController& c : scenario.controllers) {
    if (c.config.kind == ControllerKind::kKinematicBaseline) return c;
  }
  throw ConfigError("tune: scenario '" + scenario.name + "' (" + scenario.file +
                    ") has no kinematic_baseline controller to compare against");
}

void summarise(CandidateScore* score) {
  double log_sum = 0.0;
  score->unacceptable = 0;
  for (const ScenarioScore& s : score->scenarios) {
    log_sum += std::log(std::max(s.wear_ratio, 1e-12));
    if (!s.acceptable()) ++score->unacceptable;
  }
  score->geomean_wear_ratio = score->scenarios.empty() ? 0.0 : std::exp(log_sum / static_cast<double>(score->scenarios.size()));
}

}  // namespace

QualityCandidates quality_candidates(const ControllerConfig& controller, const QualityTuningOptions& options,
                                     double control_period) {
  QualityCandidates out;
  // Knots are the sa backend's alone: the others' candidates carry 0. A dt within a nanosecond of
  // another is the same (0.05 typed and 0.05 read from a target file).
  const auto add = [&](const std::string& backend, double dt, int horizon, int knots, double margin, double period) {
    const TuningCandidate candidate{horizon, backend == "sa" ? std::min(knots, horizon) : 0, margin, backend, dt,
                                    period};
    for (std::size_t i = 0; i < out.candidates.size(); ++i) {
      const TuningCandidate& c = out.candidates[i];
      if (c.backend == candidate.backend && c.horizon == candidate.horizon && std::abs(c.dt - candidate.dt) < 1e-9 &&
          std::abs(c.control_period - candidate.control_period) < 1e-9 && c.knots == candidate.knots &&
          c.deadline_margin == candidate.deadline_margin) {
        return static_cast<int>(i);
      }
    }
    out.candidates.push_back(candidate);
    return static_cast<int>(out.candidates.size()) - 1;
  };
  const std::vector<double> margins =
      options.deadline_margins.empty() ? std::vector<double>{controller.mpc.deadline_margin} : options.deadline_margins;
  const std::vector<std::string> backends =
      options.backends.empty() ? std::vector<std::string>{controller.solver.backend} : options.backends;
  const std::vector<double> periods = options.periods.empty() ? std::vector<double>{control_period} : options.periods;
  for (const std::string& backend : backends) {
    for (const double period : periods) {
      // The target's own period is carried as 0, as the incumbent's is.
      const double candidate_period = std::abs(period - control_period) < 1e-9 ? 0.0 : period;
      const std::vector<double> dts = options.dts.empty() ? std::vector<double>{period} : options.dts;
      for (const double dt : dts) {
        if (dt < period - 1e-9) continue;  // a cycle must not skip a prediction step
        for (const int horizon : options.horizons) {
          const std::vector<int> knot_counts = backend == "sa" ? options.knots : std::vector<int>{0};
          for (const int knots : knot_counts) {
            for (const double margin : margins) add(backend, dt, horizon, knots, margin, candidate_period);
          }
        }
      }
    }
  }
  const int knots_given = controller.solver.sa.knots > 0 ? controller.solver.sa.knots : controller.mpc.horizon;
  // The file's own step: its period's (run at the target's), or its own dt when longer than its period.
  const double own_dt = controller.mpc.dt > controller.mpc.period() ? controller.mpc.dt : control_period;
  out.incumbent =
      add(controller.solver.backend, own_dt, controller.mpc.horizon, knots_given, controller.mpc.deadline_margin, 0.0);
  return out;
}

std::vector<double> QualityTuningOptions::periods_tried(const TargetConfig& target) const {
  validate();
  const double period = target.control_period;
  std::vector<double> tried{period};
  for (const double p : periods) {
    if (!target.budget_at(p)) {
      throw_invalid_field("QualityTuningOptions", "periods[]", p,
                          "is not a control period target " + target.name + " allows (" + target.periods_text() +
                              " s; its file's other_periods)");
    }
    if (std::abs(p - period) >= 1e-9) tried.push_back(p);
  }
  const double shortest = periods.empty() ? period : *std::min_element(periods.begin(), periods.end());
  for (const double dt : dts) {
    if (dt < shortest - 1e-9) {
      throw_invalid_field("QualityTuningOptions", "dts[]", dt,
                          "is shorter than the " + std::string(periods.empty() ? "" : "shortest tried ") +
                              "control period of target " + target.name + " (" + Bound::number(shortest) +
                              " s): a cycle must not skip a prediction step");
    }
  }
  return tried;
}

namespace {

// Scores candidates: every scenario once per seed (the scenario's own when none is given) at the
// target's period, against its kinematic baseline run once at each period tried.
class CandidateScorer {
 public:
  CandidateScorer(const ControllerConfig& controller, const TargetConfig& target,
                  const std::vector<ScenarioConfig>& scenarios, std::vector<double> periods,
                  const QualityTuningOptions& options)
      : controller_(controller), target_(target), scenarios_(scenarios), periods_(std::move(periods)),
        options_(options) {
    baselines_.resize(periods_.size());
    for (const ScenarioConfig& scenario : scenarios_) run_baselines(scenario);
  }

  // A candidate on one scenario: the median over the seeds of each ratio and error (a run's noise
  // is larger than many candidates' differences), the misses and fallbacks summed.
  ScenarioScore score(const TuningCandidate& candidate, std::size_t index) const {
    const double period = target_.control_period;
    ScenarioController entry{"wear_mpc", "", controller_};
    const double candidate_period = candidate.period_at(period);
    const std::size_t own = period_index(candidate);
    entry.config.set_sampling(candidate.horizon, candidate.step_at(period));
    entry.config.mpc.control_period = candidate_period;
    entry.config.mpc.solve_budget =
        target_.budget_at(candidate_period).value_or(target_.solve_budget) / target_.cpu_slowdown;
    entry.config.solver.backend = candidate.backend;
    if (candidate.backend == "sa") entry.config.solver.sa.knots = candidate.knots;
    entry.config.mpc.deadline_margin = candidate.deadline_margin;
    ScenarioScore s;
    s.scenario = scenarios_[index].name;
    s.completed = true;
    std::vector<double> wear, rmse, baseline_rmse, heading, baseline_heading, step_p99, target_period_rmse;
    for (std::size_t k = 0; k < runs_[index].size(); ++k) {
      const CountedRun counted =
          run_counting_recurring_misses(at_period(runs_[index][k], candidate_period), entry, options_.clock);
      const ControllerRun& run = counted.run;
      s.unconfirmed_misses += counted.unconfirmed;
      const RunMetrics& b = baselines_[0][index][k];        // the target's period: the wear yardstick
      const RunMetrics& b_own = baselines_[own][index][k];  // the candidate's period
      s.completed = s.completed && run.completed;
      wear.push_back(b.wear_total > 0.0 ? run.metrics.wear_total / b.wear_total : 1.0);
      rmse.push_back(run.metrics.tracking_rmse_m);
      baseline_rmse.push_back(std::min(b.tracking_rmse_m, b_own.tracking_rmse_m));
      target_period_rmse.push_back(b.tracking_rmse_m);
      heading.push_back(run.metrics.heading_rmse_rad);
      baseline_heading.push_back(std::min(b.heading_rmse_rad, b_own.heading_rmse_rad));
      step_p99.push_back(run.metrics.step_time_p99_ms);
      s.deadline_misses += counted.misses;
      s.fallbacks += run.metrics.fallbacks;
    }
    s.wear_ratio = median(wear);
    s.rmse_m = median(rmse);
    s.baseline_rmse_m = median(baseline_rmse);
    s.target_period_baseline_rmse_m = median(target_period_rmse);
    s.heading_rmse_rad = median(heading);
    s.baseline_heading_rmse_rad = median(baseline_heading);
    s.step_p99_ms = *std::max_element(step_p99.begin(), step_p99.end());
    return s;
  }

 private:
  void run_baselines(const ScenarioConfig& scenario) {
    runs_.emplace_back();
    const std::vector<std::uint64_t> seeds =
        options_.seeds.empty() ? std::vector<std::uint64_t>{scenario.simulator.seed} : options_.seeds;
    for (const std::uint64_t seed : seeds) {
      runs_.back().push_back(at_period(scenario, target_.control_period));
      runs_.back().back().simulator.seed = seed;
    }
    for (std::size_t p = 0; p < periods_.size(); ++p) {
      baselines_[p].emplace_back();
      ScenarioController baseline = baseline_of(scenario);
      baseline.config.set_sampling(baseline.config.baseline.horizon, periods_[p]);
      for (const ScenarioConfig& run_config : runs_.back()) {
        const ControllerRun run = run_controller(at_period(run_config, periods_[p]), baseline, {}, 0, options_.clock);
        if (!run.completed) {
          throw ConfigError("tune: the baseline failed on '" + scenario.name + "' (seed " +
                            std::to_string(run_config.simulator.seed) + ", period " + std::to_string(periods_[p]) +
                            " s): " + run.failure);
        }
        baselines_[p].back().push_back(run.metrics);
      }
    }
  }

  std::size_t period_index(const TuningCandidate& c) const {
    const double p = c.period_at(target_.control_period);
    for (std::size_t i = 0; i < periods_.size(); ++i) {
      if (std::abs(periods_[i] - p) < 1e-9) return i;
    }
    return 0;  // not reached: every candidate's period is one of periods_
  }

  static double median(std::vector<double> values) {
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  }

  const ControllerConfig& controller_;
  const TargetConfig& target_;
  const std::vector<ScenarioConfig>& scenarios_;
  std::vector<double> periods_;
  const QualityTuningOptions& options_;
  std::vector<std::vector<ScenarioConfig>> runs_;                // [scenario][seed], at the target's period
  std::vector<std::vector<std::vector<RunMetrics>>> baselines_;  // [period][scenario][seed]
};

// Scores `score`'s candidate on every scenario after the first, which round 1 scored.
void score_on_the_rest(const CandidateScorer& scorer, std::size_t scenarios, CandidateScore* score) {
  for (std::size_t index = 1; index < scenarios; ++index) score->scenarios.push_back(scorer.score(score->candidate, index));
  score->finalist = true;
  summarise(score);
}

}  // namespace

QualityTuningResult tune_by_quality(const ControllerConfig& controller, const TargetConfig& target,
                                    const std::vector<ScenarioConfig>& scenarios, const QualityTuningOptions& options,
                                    const TuningProgress& progress) {
  target.validate();
  std::vector<double> periods = options.periods_tried(target);
  require_wear_mpc(controller, "tune");
  if (scenarios.empty()) throw ConfigError("tune: no scenario to score the candidates on");
  QualityTuningResult result;
  result.budget_here_s = target.solve_budget / target.cpu_slowdown;
  const CandidateScorer scorer(controller, target, scenarios, std::move(periods), options);

  // Round 1: every candidate on the first scenario; the controller's own setting is one of them.
  const QualityCandidates listed = quality_candidates(controller, options, target.control_period);
  for (const TuningCandidate& candidate : listed.candidates) {
    CandidateScore score;
    score.candidate = candidate;
    result.candidates.push_back(score);
  }
  result.incumbent = listed.incumbent;
  const int total = static_cast<int>(result.candidates.size());
  for (int i = 0; i < total; ++i) {
    CandidateScore& score = result.candidates[static_cast<std::size_t>(i)];
    score.scenarios.push_back(scorer.score(score.candidate, 0));
    summarise(&score);
    if (progress) progress(i + 1, total, 1);
  }
  // Ranked by the rule on the first scenario (every candidate and the incumbent ran it alone).
  const std::vector<int> order = rank_candidates(result.candidates, result.incumbent);
  // Round 2: the better half, and the controller's own setting (the comparison), on every scenario.
  std::vector<int> finalists(order.begin(), order.begin() + std::max(1, (total + 1) / 2));
  if (std::find(finalists.begin(), finalists.end(), result.incumbent) == finalists.end()) {
    finalists.push_back(result.incumbent);
  }
  for (std::size_t rank = 0; rank < finalists.size(); ++rank) {
    score_on_the_rest(scorer, scenarios.size(), &result.candidates[static_cast<std::size_t>(finalists[rank])]);
    if (progress) progress(static_cast<int>(rank) + 1, static_cast<int>(finalists.size()), 2);
  }
  result.best = best_candidate(result.candidates, result.incumbent);
  // Round 3, only when no finalist was acceptable everywhere (one scenario is a rough predictor of
  // the others): the rest, in round 1's order, on every scenario, until one is.
  const int rest = total - static_cast<int>(finalists.size());
  int done = 0;
  for (std::size_t rank = 0; rank < order.size() && result.best < 0; ++rank) {
    CandidateScore& score = result.candidates[static_cast<std::size_t>(order[rank])];
    if (score.finalist) continue;
    score_on_the_rest(scorer, scenarios.size(), &score);
    if (progress) progress(++done, rest, 3);
    result.best = best_candidate(result.candidates, result.incumbent);
  }
  if (result.best < 0) result.closest = closest_candidate(result.candidates, scenarios.size());
  return result;
}

}  // namespace swerve
