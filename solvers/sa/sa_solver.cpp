#include "swerve/solvers/sa_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "swerve/config/config_error.hpp"
#include "swerve/random.hpp"

namespace swerve {
namespace {

template <typename Value>
[[noreturn]] void reject(const char* field, const Value& value, const char* rule) {
  throw_invalid_field("SaOptions", field, value, rule);
}

std::uint64_t rotate_left(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

constexpr int kProbeMoves = 16;  // greedy probes whose uphill steps calibrate T0

}  // namespace

void SaOptions::validate() const {
  if (knots < 0) reject("knots", knots, "must be >= 0 (0: one knot per step)");
  if (max_iterations < 1) reject("max_iterations", max_iterations, "must be >= 1");
  if (!(initial_acceptance > 0.0 && initial_acceptance < 1.0)) {
    reject("initial_acceptance", initial_acceptance, "must be in (0, 1)");
  }
  if (!(final_temperature_ratio > 0.0 && final_temperature_ratio <= 1.0)) {
    reject("final_temperature_ratio", final_temperature_ratio, "must be in (0, 1]");
  }
  if (!(step_fraction > 0.0 && step_fraction <= 1.0)) reject("step_fraction", step_fraction, "must be in (0, 1]");
  if (!(target_acceptance > 0.0 && target_acceptance < 1.0)) {
    reject("target_acceptance", target_acceptance, "must be in (0, 1)");
  }
  if (adapt_interval < 1) reject("adapt_interval", adapt_interval, "must be >= 1");
  if (reheat_interval < 0) reject("reheat_interval", reheat_interval, "must be >= 0");
  if (!(probability_one_group >= 0.0 && probability_one_knot >= 0.0 &&
        probability_one_group + probability_one_knot <= 1.0)) {
    reject("probability_one_group", probability_one_group,
           "must be >= 0, and with probability_one_knot (also >= 0) sum to at most 1");
  }
}

SimulatedAnnealingSolver::SimulatedAnnealingSolver(const OcpProblem& problem, SaOptions options)
    : Solver(problem), options_(options), nx_(problem.state_size()), nu_(problem.input_size()), horizon_(problem.horizon()) {
  options_.validate();
  knot_count_ = (options_.knots == 0 || options_.knots > horizon_) ? horizon_ : options_.knots;
  group_size_ = problem.model().input_group_size();
  std::uint64_t seed_state = options_.seed;
  for (auto& word : rng_state_) word = splitmix64(&seed_state);

  // Knot k sits at step tau_k = k (N-1)/(K-1); steps between knots interpolate linearly.
  const auto n = static_cast<std::size_t>(horizon_);
  const auto k_count = static_cast<std::size_t>(knot_count_);
  knot_left_.resize(n);
  knot_weight_.resize(n);
  knot_first_step_.assign(k_count, horizon_);
  knot_last_step_.assign(k_count, -1);
  const double spacing = knot_count_ > 1 ? static_cast<double>(horizon_ - 1) / (knot_count_ - 1) : 1.0;
  for (int k = 0; k < horizon_; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    int left = knot_count_ > 1 ? std::min(static_cast<int>(std::floor(k / spacing)), knot_count_ - 2) : 0;
    const double weight = knot_count_ > 1 ? (k - left * spacing) / spacing : 0.0;
    knot_left_[kk] = left;
    knot_weight_[kk] = weight;
    for (int j : {left, std::min(left + 1, knot_count_ - 1)}) {
      const auto jj = static_cast<std::size_t>(j);
      knot_first_step_[jj] = std::min(knot_first_step_[jj], k);
      knot_last_step_[jj] = std::max(knot_last_step_[jj], k);
    }
  }

  base_ = Eigen::MatrixXd::Zero(nu_, horizon_);
  knots_ = candidate_knots_ = Eigen::MatrixXd::Zero(nu_, knot_count_);
  raw_ = candidate_raw_ = inputs_ = candidate_inputs_ = Eigen::MatrixXd::Zero(nu_, horizon_);
  states_ = candidate_states_ = Eigen::MatrixXd::Zero(nx_, horizon_ + 1);
  stage_costs_ = candidate_stage_costs_ = Eigen::VectorXd::Zero(horizon_);
  // The proposal scale of each input: its half-range, or its per-step bound, or 1 when unbounded.
  reference_step_ = Eigen::VectorXd::Ones(nu_);
  const InputBounds& bounds = problem.bounds();
  for (int i = 0; i < nu_; ++i) {
    const double half_range = 0.5 * (bounds.upper[i] - bounds.lower[i]);
    if (std::isfinite(half_range) && half_range > 0.0) {
      reference_step_[i] = half_range;
    } else if (std::isfinite(bounds.max_step[i])) {
      reference_step_[i] = bounds.max_step[i] * horizon_;
    }
  }
  sigma_ = reference_step_ * options_.step_fraction;
}

double SimulatedAnnealingSolver::uniform() noexcept {
  // xoshiro256** (Blackman & Vigna): fast, and the same stream on every platform for a seed.
  const std::uint64_t result = rotate_left(rng_state_[1] * 5, 7) * 9;
  const std::uint64_t t = rng_state_[1] << 17;
  rng_state_[2] ^= rng_state_[0];
  rng_state_[3] ^= rng_state_[1];
  rng_state_[1] ^= rng_state_[2];
  rng_state_[0] ^= rng_state_[3];
  rng_state_[2] ^= t;
  rng_state_[3] = rotate_left(rng_state_[3], 45);
  return static_cast<double>(result >> 11) * 0x1.0p-53;
}

double SimulatedAnnealingSolver::gaussian() noexcept {
  if (has_spare_gaussian_) {
    has_spare_gaussian_ = false;
    return spare_gaussian_;
  }
  const double u1 = 1.0 - uniform();  // (0, 1]: log is finite
  const double u2 = uniform();
  const double radius = std::sqrt(-2.0 * std::log(u1));
  spare_gaussian_ = radius * std::sin(2.0 * 3.14159265358979323846 * u2);
  has_spare_gaussian_ = true;
  return radius * std::cos(2.0 * 3.14159265358979323846 * u2);
}

void SimulatedAnnealingSolver::interpolate(const Eigen::MatrixXd& knots, int first, int last,
                                           Eigen::MatrixXd* raw) const noexcept {
  for (int k = first; k <= last; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    const Eigen::Index left = knot_left_[kk];
    const Eigen::Index right = std::min<Eigen::Index>(left + 1, knot_count_ - 1);
    const double w = knot_weight_[kk];
    raw->col(k) = base_.col(k) + (1.0 - w) * knots.col(left) + w * knots.col(right);
  }
}

SolveStatus SimulatedAnnealingSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses,
                                               Deadline deadline, Solution* out, SolveSummary* summary) noexcept {
  long rollouts = 0;
  const double start_cost = cheapest_start(problem, guesses, base_, states_, candidate_inputs_, candidate_states_,
                                           candidate_stage_costs_, &rollouts);
  if (!std::isfinite(start_cost)) {
    summary->reason = "the model failed on every initial guess";
    summary->rollouts = rollouts;
    return SolveStatus::kNumericalError;
  }
  knots_.setZero();
  raw_ = base_;
  inputs_ = base_;
  const auto rollout_start = deadline.now();
  double current_cost = problem.rollout(inputs_, 0, states_, stage_costs_);
  // The longest a proposal can take (a full rollout). The loop stops while one more proposal and the
  // final cost evaluation still fit before the deadline, so the solver returns on time.
  const auto full_rollout = deadline.now() - rollout_start;
  const auto loop_start = deadline.now();
  const double loop_budget = to_seconds(deadline.at() - 2 * full_rollout - loop_start);
  ++rollouts;
  summary->initial_cost = current_cost;
  out->inputs = inputs_;
  out->states = states_;
  double best_cost = current_cost;

  // Geometric cooling over the schedule's progress: the larger of the share of iterations done and
  // the share of the time budget used, so a deadline-limited solve still cools all the way.
  double initial_temperature = std::numeric_limits<double>::infinity();
  double temperature = initial_temperature;
  double progress_at_reheat = 0.0;
  double uphill_sum = 0.0;
  int uphill_count = 0;
  int window_proposed = 0, window_accepted = 0;
  int iteration = 0, probes = 0;
  bool deadline_hit = false;
  const int groups = nu_ / group_size_;

  auto longest_proposal = full_rollout;  // grows if a proposal ever takes longer than a full rollout
  auto now = deadline.now();
  for (; iteration < options_.max_iterations; ++iteration) {
    const auto proposal_start = now;
    // Room for one more proposal, the final evaluation, and one rollout's worth of slack for the
    // scheduler (measured overruns without it: up to 0.2 ms on a 20 ms budget).
    if (proposal_start + longest_proposal + 2 * full_rollout >= deadline.at()) {
      deadline_hit = true;
      break;
    }
    const double time_progress =
        loop_budget > 0.0 ? std::chrono::duration<double>(proposal_start - loop_start).count() / loop_budget : 1.0;
    const double progress =
        std::max(static_cast<double>(iteration) / options_.max_iterations, time_progress) - progress_at_reheat;
    // Propose: perturb knot offsets (one group at one knot, all inputs at one knot, or everything).
    candidate_knots_ = knots_;
    const double choice = uniform();
    int first_step = 0, last_step = horizon_ - 1;
    if (choice < options_.probability_one_group + options_.probability_one_knot) {
      const int knot = std::min(static_cast<int>(uniform() * knot_count_), knot_count_ - 1);
      int first_input = 0, count = nu_;
      if (choice < options_.probability_one_group) {
        first_input = std::min(static_cast<int>(uniform() * groups), groups - 1) * group_size_;
        count = group_size_;
      }
      for (int i = first_input; i < first_input + count; ++i) candidate_knots_(i, knot) += sigma_[i] * gaussian();
      first_step = knot_first_step_[static_cast<std::size_t>(knot)];
      last_step = knot_last_step_[static_cast<std::size_t>(knot)];
    } else {
      const double shrink = 1.0 / std::sqrt(static_cast<double>(knot_count_));
      for (int j = 0; j < knot_count_; ++j) {
        for (int i = 0; i < nu_; ++i) candidate_knots_(i, j) += shrink * sigma_[i] * gaussian();
      }
    }
    candidate_raw_ = raw_;
    interpolate(candidate_knots_, first_step, last_step, &candidate_raw_);
    candidate_inputs_ = candidate_raw_;
    problem.project(candidate_inputs_);
    // Only steps from the first changed input on need a new rollout; the prefix is shared.
    int changed = horizon_;
    for (int k = 0; k < horizon_ && changed == horizon_; ++k) {
      if (candidate_inputs_.col(k) != inputs_.col(k)) changed = k;
    }
    if (changed == horizon_) {  // the projection undid the move
      now = deadline.now();
      continue;
    }
    candidate_states_.leftCols(changed + 1) = states_.leftCols(changed + 1);
    candidate_stage_costs_.head(changed) = stage_costs_.head(changed);
    const double candidate_cost = problem.rollout(candidate_inputs_, changed, candidate_states_, candidate_stage_costs_);
    ++rollouts;
    now = deadline.now();
    longest_proposal = std::max(longest_proposal, now - proposal_start);
    const double delta = candidate_cost - current_cost;

    bool accept = false;
    if (probes < kProbeMoves) {
      // Calibration: greedy, recording uphill steps to set T0 (paper-notes assumption 8).
      accept = delta <= 0.0;
      if (delta > 0.0 && std::isfinite(delta)) {
        uphill_sum += delta;
        ++uphill_count;
      }
      if (++probes == kProbeMoves) {
        const double typical_uphill = uphill_count > 0 ? uphill_sum / uphill_count : 1e-9 * (1.0 + current_cost);
        initial_temperature = -typical_uphill / std::log(options_.initial_acceptance);
      }
    } else {
      temperature = initial_temperature * std::pow(options_.final_temperature_ratio, std::max(0.0, progress));
      accept = delta <= 0.0 || (std::isfinite(delta) && uniform() < std::exp(-delta / temperature));
    }
    ++window_proposed;
    if (accept) {
      ++window_accepted;
      std::swap(knots_, candidate_knots_);
      std::swap(raw_, candidate_raw_);
      std::swap(inputs_, candidate_inputs_);
      std::swap(states_, candidate_states_);
      std::swap(stage_costs_, candidate_stage_costs_);
      current_cost = candidate_cost;
      if (current_cost < best_cost) {
        best_cost = current_cost;
        out->inputs = inputs_;
        out->states = states_;
      }
    }
    if (window_proposed >= options_.adapt_interval) {
      const double rate = static_cast<double>(window_accepted) / window_proposed;
      const double factor = rate > options_.target_acceptance ? 1.25 : 0.8;
      sigma_ = (sigma_ * factor).cwiseMax(1e-6 * reference_step_).cwiseMin(2.0 * reference_step_);
      window_proposed = window_accepted = 0;
    }
    if (options_.reheat_interval > 0 && iteration > 0 && iteration % options_.reheat_interval == 0) {
      // Restart from the best plan seen, warmer: escapes a basin without losing the best.
      raw_ = out->inputs;  // the best plan, as raw inputs with zero offsets
      base_ = out->inputs;
      knots_.setZero();
      inputs_ = out->inputs;
      current_cost = problem.rollout(inputs_, 0, states_, stage_costs_);
      ++rollouts;
      now = deadline.now();
      // Warmer again: half of the way back up the schedule.
      progress_at_reheat += 0.5 * std::max(0.0, progress);
    }
  }
  out->cost = best_cost;
  summary->iterations = iteration;
  summary->rollouts = rollouts;
  summary->cost = problem.evaluate(out->inputs, candidate_states_);
  if (deadline_hit) {
    summary->reason = "stopped at the deadline with the best plan seen";
    return SolveStatus::kBudgetExhausted;
  }
  summary->reason = "completed the annealing schedule";
  return SolveStatus::kConverged;
}

}  // namespace swerve
