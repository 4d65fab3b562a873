#include "swerve/solvers/sa_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "projected_lbfgs.hpp"
#include "swerve/core/config_error.hpp"
#include "worker_pool.hpp"

namespace swerve {
namespace {

// The owner every rule of this file names (throw_invalid_field: "<owner>.<field> = <value>: <rule>").
constexpr const char* kOwner = "SaOptions";

constexpr int kProbeMoves = 16;  // greedy probes whose uphill steps calibrate T0
constexpr int kPolishMemory = 5;  // L-BFGS pairs kept
// The knot polish's forward-difference step, per unit of each input's reference step (its
// half-range): large enough that the prediction's Newton tolerance (1e-10 on the twist) stays ~1e-5
// of a slope, small enough that the curvature's bias is as small.
constexpr double kKnotDifference = 1e-4;
constexpr int kMaxThreads = 16;
// polish()'s answer when not even its first gradient fits before its stop.
constexpr int kGradientDoesNotFit = -1;

}  // namespace

const OptionFields<SaOptions>& SaOptions::fields() {
  static const OptionFields<SaOptions> table{
      {"knots", &SaOptions::knots, Bound::at_least(0), {}, nullptr, "(0: one knot per step)"},
      {"max_iterations", &SaOptions::max_iterations, Bound::at_least(1)},
      {"initial_acceptance", &SaOptions::initial_acceptance, Bound::open(0.0, 1.0)},
      {"final_temperature_ratio", &SaOptions::final_temperature_ratio, Bound::half_open(0.0, 1.0)},
      {"step_fraction", &SaOptions::step_fraction, Bound::half_open(0.0, 1.0)},
      {"target_acceptance", &SaOptions::target_acceptance, Bound::open(0.0, 1.0)},
      {"adapt_interval", &SaOptions::adapt_interval, Bound::at_least(1)},
      {"reheat_interval", &SaOptions::reheat_interval, Bound::at_least(0)},
      {"probability_one_group", &SaOptions::probability_one_group, Bound::closed(0.0, 1.0)},
      {"probability_one_knot", &SaOptions::probability_one_knot, Bound::closed(0.0, 1.0)},
      {"polish_share", &SaOptions::polish_share, Bound::right_open(0.0, 1.0)},
      {"polish_iterations", &SaOptions::polish_iterations, Bound::at_least(0)},
      {"knot_polish", &SaOptions::knot_polish},
      {"threads", &SaOptions::threads, Bound::closed(1, kMaxThreads)},
  };
  return table;
}

void SaOptions::validate() const {
  check_fields("SaOptions", *this, fields());
  if (probability_one_group + probability_one_knot > 1.0) {
    throw_invalid_field(kOwner, "probability_one_group", probability_one_group,
           "must be >= 0, and with probability_one_knot (also >= 0) sum to at most 1");
  }
}

SimulatedAnnealingSolver::SimulatedAnnealingSolver(const OcpProblem& problem, SaOptions options)
    : Solver(problem, std::clamp(options.threads, 1, kMaxThreads)),  // validated below
      options_(options),
      nx_(problem.state_size()),
      nu_(problem.input_size()),
      horizon_(problem.horizon()),
      random_(options.seed),
      start_(problem) {
  options_.validate();
  knot_count_ = (options_.knots == 0 || options_.knots > horizon_) ? horizon_ : options_.knots;
  group_size_ = problem.model().input_group_size();

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
  stage_wear_ = candidate_stage_wear_ = best_stage_wear_ = Eigen::VectorXd::Zero(horizon_);
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
  best_stage_costs_ = Eigen::VectorXd::Zero(horizon_);
  proposals_.resize(static_cast<std::size_t>(options_.threads - 1));
  for (Proposal& p : proposals_) {
    p.knots = Eigen::MatrixXd::Zero(nu_, knot_count_);
    p.raw = p.inputs = Eigen::MatrixXd::Zero(nu_, horizon_);
    p.states = Eigen::MatrixXd::Zero(nx_, horizon_ + 1);
    p.stage_costs = p.stage_wear = Eigen::VectorXd::Zero(horizon_);
    p.x_next = Eigen::VectorXd::Zero(nx_);
  }
  x_next_ = Eigen::VectorXd::Zero(nx_);
  if (!proposals_.empty()) workers_ = std::make_unique<WorkerPool>(options_.threads - 1, [this](std::size_t w) { run_worker_job(w); });
  if (options_.polish_share > 0.0 && options_.polish_iterations > 0) {
    if (problem.model().has_jacobians()) derivatives_ = std::make_unique<OcpDerivatives>(problem);
    gradient_ = candidate_gradient_ = direction_ = Eigen::MatrixXd::Zero(nu_, horizon_);
    knot_gradient_ = candidate_knot_gradient_ = knot_direction_ = previous_knots_ = Eigen::MatrixXd::Zero(nu_, knot_count_);
    lbfgs_ = std::make_unique<LbfgsMemory>(static_cast<Eigen::Index>(nu_) * horizon_, kPolishMemory);
  }
}

SimulatedAnnealingSolver::~SimulatedAnnealingSolver() = default;

int SimulatedAnnealingSolver::stages_per_thread() const noexcept {
  const int threads = static_cast<int>(proposals_.size()) + 1;
  return (horizon_ + threads - 1) / threads;
}

void SimulatedAnnealingSolver::run_worker_job(std::size_t index) noexcept {
  if (worker_job_ == WorkerJob::kLinearise) {
    Proposal& p = proposals_[index];
    p.done_stages = derivatives_->linearize_stages(*batch_problem_, *job_inputs_, *job_states_, p.first_stage,
                                                   p.last_stage, model_data(static_cast<int>(index) + 1), p.x_next,
                                                   job_stop_);
  } else {
    roll_out_proposal(index);
  }
}

double SimulatedAnnealingSolver::exact_gradient(const OcpProblem& problem, const Eigen::MatrixXd& inputs,
                                                Eigen::MatrixXd& states, Eigen::MatrixXd* gradient,
                                                const Deadline& give_up, double* done) noexcept {
  if (proposals_.empty()) {
    const double cost = derivatives_->cost_and_gradient(problem, inputs, states, *gradient, &give_up);
    *done = static_cast<double>(derivatives_->completed_stages()) / horizon_;
    return cost;
  }
  // With workers: the stages of the known rollout split into contiguous shares, the first here and
  // one on each worker (each on its own scratch), then the adjoint recursion here.
  const int share = stages_per_thread();
  for (std::size_t w = 0; w < proposals_.size(); ++w) {
    Proposal& p = proposals_[w];
    p.first_stage = std::min(horizon_, static_cast<int>(w + 1) * share);
    p.last_stage = std::min(horizon_, p.first_stage + share);
  }
  gradient->setZero();
  batch_problem_ = &problem;
  job_inputs_ = &inputs;
  job_states_ = &states;
  job_stop_ = &give_up;
  worker_job_ = WorkerJob::kLinearise;
  workers_->start();
  const int first_share = std::min(share, horizon_);
  const int here =
      derivatives_->linearize_stages(problem, inputs, states, 0, first_share, model_data(), x_next_, &give_up);
  workers_->wait();
  worker_job_ = WorkerJob::kProposal;
  bool failed = here < 0;
  double least = first_share > 0 ? static_cast<double>(std::max(here, 0)) / first_share : 1.0;
  for (const Proposal& p : proposals_) {
    const int stages = p.last_stage - p.first_stage;
    if (stages <= 0) continue;
    failed = failed || p.done_stages < 0;
    least = std::min(least, static_cast<double>(std::max(p.done_stages, 0)) / stages);
  }
  *done = least;
  if (failed) return std::numeric_limits<double>::infinity();
  if (least < 1.0) return std::numeric_limits<double>::quiet_NaN();
  return derivatives_->gradient_of_stages(problem, inputs, states, *gradient);
}

void SimulatedAnnealingSolver::roll_out_proposal(std::size_t index) noexcept {
  Proposal& p = proposals_[index];
  if (p.changed >= horizon_) return;
  p.cost = roll_out_from(*batch_problem_, model_data(static_cast<int>(index) + 1), p.changed, p.inputs, p.states,
                         p.stage_costs, p.stage_wear);
}

int SimulatedAnnealingSolver::first_changed_step(const Eigen::MatrixXd& inputs, int first, int last) const noexcept {
  for (int k = first; k <= last; ++k) {
    if (inputs.col(k) != inputs_.col(k)) return k;
  }
  return horizon_;
}

double SimulatedAnnealingSolver::roll_out_from(const OcpProblem& problem, PredictionData& data, int changed,
                                               const Eigen::MatrixXd& inputs, Eigen::MatrixXd& states,
                                               Eigen::VectorXd& stage_costs,
                                               Eigen::VectorXd& stage_wear) const noexcept {
  states.leftCols(changed + 1) = states_.leftCols(changed + 1);
  stage_costs.head(changed) = stage_costs_.head(changed);
  stage_wear.head(changed) = stage_wear_.head(changed);
  return problem.rollout(data, inputs, changed, states, stage_costs, stage_wear.data());
}

int SimulatedAnnealingSolver::propose(const OcpProblem& problem, Eigen::MatrixXd* knots, Eigen::MatrixXd* raw,
                                      Eigen::MatrixXd* inputs) noexcept {
  // Perturb knot offsets: one group at one knot, all inputs at one knot, or everything.
  const int groups = nu_ / group_size_;
  *knots = knots_;
  const double choice = random_.uniform();
  int first_step = 0, last_step = horizon_ - 1;
  if (choice < options_.probability_one_group + options_.probability_one_knot) {
    const int knot = std::min(static_cast<int>(random_.uniform() * knot_count_), knot_count_ - 1);
    int first_input = 0, count = nu_;
    if (choice < options_.probability_one_group) {
      first_input = std::min(static_cast<int>(random_.uniform() * groups), groups - 1) * group_size_;
      count = group_size_;
    }
    for (int i = first_input; i < first_input + count; ++i) (*knots)(i, knot) += sigma_[i] * random_.gaussian();
    first_step = knot_first_step_[static_cast<std::size_t>(knot)];
    last_step = knot_last_step_[static_cast<std::size_t>(knot)];
  } else {
    const double shrink = 1.0 / std::sqrt(static_cast<double>(knot_count_));
    for (int j = 0; j < knot_count_; ++j) {
      for (int i = 0; i < nu_; ++i) (*knots)(i, j) += shrink * sigma_[i] * random_.gaussian();
    }
  }
  *raw = raw_;
  interpolate(*knots, first_step, last_step, raw);
  *inputs = *raw;
  problem.project(*inputs);
  // Only steps from the first changed input on need a new rollout; the prefix is shared.
  return first_changed_step(*inputs, 0, horizon_ - 1);
}

bool SimulatedAnnealingSolver::lbfgs_direction(const Eigen::MatrixXd& gradient, Eigen::MatrixXd* direction) noexcept {
  const Eigen::Index n = gradient.size();
  const Eigen::Map<const Eigen::VectorXd> g(gradient.data(), n);
  Eigen::Map<Eigen::VectorXd> d(direction->data(), n);
  d = -g;
  if (lbfgs_->empty()) {
    // No curvature yet: a first step of 2 % of the largest input range along the gradient.
    // In inputs scaled by their ranges the gradient is g_i r_i; a step of 2 % of the largest
    // scaled input is r_i^2 g_i times 0.02 / max |g_i r_i| in the inputs themselves.
    const double largest = (gradient.array().abs().colwise() * reference_step_.array()).maxCoeff();
    if (!(largest > 0.0)) return false;
    d *= 0.02 / largest;
    for (int i = 0; i < nu_; ++i) direction->row(i) *= reference_step_[i] * reference_step_[i];
  }
  return lbfgs_->apply_inverse_hessian(g, d);
}

int SimulatedAnnealingSolver::polish(const OcpProblem& problem, Deadline deadline, TimePoint stop,
                                     Duration full_rollout, Solution* out, long* rollouts) noexcept {
  // Projected L-BFGS (Nocedal & Wright, Numerical Optimization, 2nd ed., Alg. 7.4) with an Armijo
  // backtracking search on the true cost; projection by OcpProblem::project. Each step is kept only
  // if it lowers the cost, so the polish never returns a worse plan than the annealer's best.
  const Eigen::Index n = static_cast<Eigen::Index>(nu_) * horizon_;
  const auto flat = [n](Eigen::MatrixXd& m) { return Eigen::Map<Eigen::VectorXd>(m.data(), n); };
  // A gradient costs several rollouts (the step's Jets). Before the first one, one stage's Jacobian
  // is timed and scaled by the horizon. The cost varies with the state (the slow-motion substeps,
  // Newton's splits), hence the 1.5x on the slowest gradient seen.
  // With workers the stages are split between the threads, so a gradient takes a share's stages.
  if (longest_gradient_ == Duration::zero()) {
    if (deadline.now() + 2 * full_rollout >= stop) return 0;
    const auto probe_start = deadline.now();
    derivatives_->linearize_stage(problem, 0, problem.initial_state(), out->inputs.col(0), candidate_states_.col(1));
    longest_gradient_ = stages_per_thread() * (deadline.now() - probe_start);
  }
  const auto gradient_time = [&] { return longest_gradient_ + longest_gradient_ / 2; };
  // Worth starting only with room for the gradient and a line search's first two trials.
  if (deadline.now() + gradient_time() + 2 * full_rollout >= stop) return kGradientDoesNotFit;
  inputs_ = out->inputs;
  states_ = out->states;  // its rollout, which the threads' gradient linearises at
  // A gradient given up after some stages is charged at its full horizon's pace.
  double done = 1.0;  // share of the last gradient's stages linearised
  const auto record_gradient_time = [&](TimePoint gradient_start) {
    const long stages = std::max(1L, std::lround(done * horizon_));
    longest_gradient_ = std::max(longest_gradient_, (deadline.now() - gradient_start) * horizon_ / stages);
  };
  const Deadline give_up = deadline.earlier_by(deadline.at() - stop);
  auto gradient_start = deadline.now();
  double cost = exact_gradient(problem, inputs_, states_, &gradient_, give_up, &done);
  record_gradient_time(gradient_start);
  ++*rollouts;
  if (!std::isfinite(cost)) return 0;
  lbfgs_->clear();
  int steps = 0;
  for (int iteration = 0; iteration < options_.polish_iterations; ++iteration) {
    if (deadline.now() + 2 * full_rollout >= stop) break;
    const bool had_memory = !lbfgs_->empty();
    if (!lbfgs_direction(gradient_, &direction_)) {
      if (had_memory) continue;  // retried along the steepest descent
      break;                     // a zero gradient
    }
    double candidate_cost = cost;
    const auto along_direction = [&](double step, double* trial_cost, double* decrease) {
      candidate_inputs_ = inputs_ + step * direction_;
      problem.project(candidate_inputs_);
      *trial_cost = problem.rollout(model_data(), candidate_inputs_, 0, candidate_states_, candidate_stage_costs_,
                                    candidate_stage_wear_.data());
      *decrease = flat(gradient_).dot(flat(candidate_inputs_) - flat(inputs_));
      return true;
    };
    if (!armijo_backtracking(cost, deadline, stop, &full_rollout, rollouts, along_direction, &candidate_cost)) break;
    ++steps;
    // The accepted point is kept even when no time is left for its gradient.
    out->inputs = candidate_inputs_;
    out->states = candidate_states_;
    best_stage_wear_ = candidate_stage_wear_;
    out->cost = candidate_cost;
    if (deadline.now() + gradient_time() >= stop) break;
    gradient_start = deadline.now();
    const double new_cost = exact_gradient(problem, candidate_inputs_, candidate_states_, &candidate_gradient_, give_up, &done);
    record_gradient_time(gradient_start);
    ++*rollouts;
    if (!std::isfinite(new_cost)) break;
    lbfgs_->remember(flat(candidate_inputs_), flat(inputs_), flat(candidate_gradient_), flat(gradient_));
    std::swap(inputs_, candidate_inputs_);
    std::swap(states_, candidate_states_);
    std::swap(gradient_, candidate_gradient_);
    cost = new_cost;
    out->inputs = inputs_;
    out->states = states_;
    out->cost = cost;
  }
  return steps;
}

double SimulatedAnnealingSolver::knot_gradient_rollouts() const noexcept {
  double steps = 0.0;
  for (int first : knot_first_step_) steps += horizon_ - first;
  return nu_ * steps / horizon_;
}

bool SimulatedAnnealingSolver::knot_gradient(const OcpProblem& problem, double cost, Deadline deadline, TimePoint stop,
                                             Duration* proposal, long* rollouts, Eigen::MatrixXd* gradient) noexcept {
  for (int knot = 0; knot < knot_count_; ++knot) {
    const int first = knot_first_step_[static_cast<std::size_t>(knot)];
    const int last = knot_last_step_[static_cast<std::size_t>(knot)];
    for (int i = 0; i < nu_; ++i) {
      const auto start = deadline.now();
      if (start + *proposal >= stop) return false;
      const double h = kKnotDifference * reference_step_[i];
      candidate_knots_ = knots_;
      candidate_knots_(i, knot) += h;
      candidate_raw_ = raw_;
      interpolate(candidate_knots_, first, last, &candidate_raw_);
      candidate_inputs_ = candidate_raw_;
      problem.project(candidate_inputs_);
      const int changed = first_changed_step(candidate_inputs_, first, last);
      if (changed == horizon_) {  // held by a bound: no slope along this offset
        (*gradient)(i, knot) = 0.0;
        continue;
      }
      const double shifted = roll_out_from(problem, model_data(), changed, candidate_inputs_, candidate_states_,
                                           candidate_stage_costs_, candidate_stage_wear_);
      ++*rollouts;
      *proposal = std::max(*proposal, deadline.now() - start);
      if (!std::isfinite(shifted)) return false;
      (*gradient)(i, knot) = (shifted - cost) / h;
    }
  }
  return true;
}

int SimulatedAnnealingSolver::knot_polish(const OcpProblem& problem, Deadline deadline, TimePoint stop,
                                          Duration proposal, Solution* out, long* rollouts) noexcept {
  // The best plan becomes the base and the offsets restart at zero, as a reheat does; the cost is
  // a smooth function of the offsets away from the bounds, which the projection holds.
  base_ = out->inputs;
  raw_ = base_;
  inputs_ = out->inputs;
  states_ = out->states;
  stage_costs_ = best_stage_costs_;
  stage_wear_ = best_stage_wear_;
  knots_.setZero();
  double cost = out->cost;
  const Eigen::Index n = knots_.size();
  const auto flat = [n](Eigen::MatrixXd& m) { return Eigen::Map<Eigen::VectorXd>(m.data(), n); };
  // A gradient costs one rollout per offset, from its knot's first step; then as measured, the
  // slowest seen.
  const auto gradient_time = [&] {
    return longest_knot_gradient_ > Duration::zero()
               ? longest_knot_gradient_
               : std::chrono::duration_cast<Duration>(knot_gradient_rollouts() * proposal);
  };
  const auto timed_gradient = [&](double at_cost, Eigen::MatrixXd* gradient) {
    const auto start = deadline.now();
    const bool complete = knot_gradient(problem, at_cost, deadline, stop, &proposal, rollouts, gradient);
    if (complete) longest_knot_gradient_ = std::max(longest_knot_gradient_, deadline.now() - start);
    return complete;
  };
  if (deadline.now() + gradient_time() + 2 * proposal >= stop) return 0;
  if (!timed_gradient(cost, &knot_gradient_)) return 0;
  lbfgs_->clear();
  int steps = 0;
  for (int iteration = 0; iteration < options_.polish_iterations; ++iteration) {
    if (deadline.now() + 2 * proposal >= stop) break;
    const bool had_memory = !lbfgs_->empty();
    if (!lbfgs_direction(knot_gradient_, &knot_direction_)) {
      if (had_memory) continue;  // retried along the steepest descent
      break;                     // a zero gradient
    }
    double candidate_cost = cost;
    const auto along_direction = [&](double step, double* trial_cost, double* decrease) {
      candidate_knots_ = knots_ + step * knot_direction_;
      interpolate(candidate_knots_, 0, horizon_ - 1, &candidate_raw_);
      candidate_inputs_ = candidate_raw_;
      problem.project(candidate_inputs_);
      const int changed = first_changed_step(candidate_inputs_, 0, horizon_ - 1);
      if (changed == horizon_) return false;  // the bounds hold every step of the move
      *trial_cost = roll_out_from(problem, model_data(), changed, candidate_inputs_, candidate_states_,
                                  candidate_stage_costs_, candidate_stage_wear_);
      *decrease = flat(knot_gradient_).dot(flat(candidate_knots_) - flat(knots_));
      return true;
    };
    if (!armijo_backtracking(cost, deadline, stop, &proposal, rollouts, along_direction, &candidate_cost)) break;
    ++steps;
    // The accepted plan becomes the current one (and the answer) even when no gradient follows.
    std::swap(raw_, candidate_raw_);
    std::swap(inputs_, candidate_inputs_);
    std::swap(states_, candidate_states_);
    std::swap(stage_costs_, candidate_stage_costs_);
    std::swap(stage_wear_, candidate_stage_wear_);
    out->inputs = inputs_;
    out->states = states_;
    best_stage_wear_ = stage_wear_;
    out->cost = cost = candidate_cost;
    // The offsets move with their plan (knot_gradient perturbs around both); candidate_knots_ is
    // its scratch, so the step is kept apart for the memory.
    previous_knots_ = knots_;
    knots_ = candidate_knots_;
    if (deadline.now() + gradient_time() >= stop) break;
    if (!timed_gradient(cost, &candidate_knot_gradient_)) break;
    lbfgs_->remember(flat(knots_), flat(previous_knots_), flat(candidate_knot_gradient_), flat(knot_gradient_));
    std::swap(knot_gradient_, candidate_knot_gradient_);
  }
  return steps;
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

SimulatedAnnealingSolver::BudgetPlan SimulatedAnnealingSolver::plan_budget(const Deadline& deadline,
                                                                           TimePoint loop_start,
                                                                           Duration full_rollout) noexcept {
  BudgetPlan plan;
  // With a polish, the annealing ends early enough to leave it its share of the budget, unless a
  // gradient as last timed (with the polish's 1.5x allowance) would not fit in that share.
  // The slowest gradient seen decays by 1/16 per solve, so one stall is forgotten in ~50 solves.
  longest_gradient_ -= longest_gradient_ / 16;
  const bool timed = deadline.at() != TimePoint::max();
  const Duration polish_window =
      timed ? std::chrono::duration_cast<Duration>(options_.polish_share * (deadline.at() - loop_start)) : Duration::max();
  plan.exact_polish = derivatives_ != nullptr &&
                      (!timed || longest_gradient_ == Duration::zero() ||
                       longest_gradient_ + longest_gradient_ / 2 + 2 * full_rollout <= polish_window);
  // Else the knot polish, when one forward-difference gradient (as last timed, or one full rollout
  // per offset before the first) and two line-search trials fit in the share.
  longest_knot_gradient_ -= longest_knot_gradient_ / 16;
  const Duration knot_gradient_estimate =
      longest_knot_gradient_ > Duration::zero()
          ? longest_knot_gradient_
          : std::chrono::duration_cast<Duration>(knot_gradient_rollouts() * full_rollout);
  // knot_gradient_ is sized only when the options ask for a polish at all.
  plan.knot_polish_allowed = options_.knot_polish && knot_gradient_.size() > 0;
  const bool knot_polishing =
      !plan.exact_polish && plan.knot_polish_allowed && (!timed || knot_gradient_estimate + 2 * full_rollout <= polish_window);
  plan.polishing = plan.exact_polish || knot_polishing;
  plan.anneal_end =
      plan.polishing && timed
          ? loop_start + std::chrono::duration_cast<Duration>((1.0 - options_.polish_share) * (deadline.at() - loop_start))
          : deadline.at();
  plan.loop_budget = to_seconds(plan.anneal_end - 2 * full_rollout - loop_start);
  return plan;
}

bool SimulatedAnnealingSolver::evaluate_batch(const OcpProblem& problem, long* rollouts,
                                              double* candidate_cost) noexcept {
  // Propose: one proposal here and, with workers, one more on each (drawn in order, so the seed
  // alone decides them).
  const int changed = propose(problem, &candidate_knots_, &candidate_raw_, &candidate_inputs_);
  int batch = 0;
  for (Proposal& p : proposals_) {
    p.changed = propose(problem, &p.knots, &p.raw, &p.inputs);
    if (p.changed < horizon_) ++batch;
  }
  if (changed == horizon_ && batch == 0) return false;  // the projection undid every move
  batch_problem_ = &problem;
  const bool parallel = batch > 0;
  if (parallel) workers_->start();
  *candidate_cost = std::numeric_limits<double>::infinity();
  if (changed < horizon_) {
    *candidate_cost = roll_out_from(problem, model_data(), changed, candidate_inputs_, candidate_states_,
                                    candidate_stage_costs_, candidate_stage_wear_);
    ++*rollouts;
  }
  if (parallel) workers_->wait();
  *rollouts += batch;
  // The cheapest of the batch is the candidate (ties: the first drawn).
  for (Proposal& p : proposals_) {
    if (p.changed < horizon_ && p.cost < *candidate_cost) {
      *candidate_cost = p.cost;
      std::swap(candidate_knots_, p.knots);
      std::swap(candidate_raw_, p.raw);
      std::swap(candidate_inputs_, p.inputs);
      std::swap(candidate_states_, p.states);
      std::swap(candidate_stage_costs_, p.stage_costs);
      std::swap(candidate_stage_wear_, p.stage_wear);
    }
  }
  return true;
}

bool SimulatedAnnealingSolver::Schedule::accepts(double delta, double progress, double initial_acceptance,
                                                 double final_temperature_ratio, double draw) noexcept {
  if (probes < kProbeMoves) {
    // Calibration: greedy, recording uphill steps to set T0 (docs/paper.md, assumption 8).
    if (delta > 0.0 && std::isfinite(delta)) {
      uphill_sum += delta;
      ++uphill_count;
    }
    if (++probes == kProbeMoves) {
      const double typical_uphill = uphill_count > 0 ? uphill_sum / uphill_count : 1e-9 * (1.0 + calibration_cost);
      initial_temperature = -typical_uphill / std::log(initial_acceptance);
    }
    return delta <= 0.0;
  }
  const double temperature = initial_temperature * std::pow(final_temperature_ratio, std::max(0.0, progress));
  return delta <= 0.0 || (std::isfinite(delta) && draw < std::exp(-delta / temperature));
}

void SimulatedAnnealingSolver::take_candidate(double candidate_cost, double* current_cost, double* best_cost,
                                              Solution* out) noexcept {
  std::swap(knots_, candidate_knots_);
  std::swap(raw_, candidate_raw_);
  std::swap(inputs_, candidate_inputs_);
  std::swap(states_, candidate_states_);
  std::swap(stage_costs_, candidate_stage_costs_);
  std::swap(stage_wear_, candidate_stage_wear_);
  *current_cost = candidate_cost;
  if (*current_cost < *best_cost) {
    *best_cost = *current_cost;
    out->inputs = inputs_;
    out->states = states_;
    best_stage_wear_ = stage_wear_;
    best_stage_costs_ = stage_costs_;
  }
}

double SimulatedAnnealingSolver::restart_from_best(const OcpProblem& problem, const Solution& best) noexcept {
  // Restart from the best plan seen, warmer: escapes a basin without losing the best.
  raw_ = best.inputs;  // the best plan, as raw inputs with zero offsets
  base_ = best.inputs;
  knots_.setZero();
  inputs_ = best.inputs;
  return problem.rollout(model_data(), inputs_, 0, states_, stage_costs_, stage_wear_.data());
}

double SimulatedAnnealingSolver::start_from_guesses(const OcpProblem& problem, const InitialGuesses& guesses,
                                                   const Deadline& deadline) noexcept {
  const double start_cost = start_.choose(problem, guesses, deadline);
  if (!std::isfinite(start_cost)) return start_cost;
  knots_.setZero();
  base_ = start_.inputs();
  raw_ = base_;
  inputs_ = base_;
  states_ = start_.states();
  stage_costs_ = start_.stage_costs();
  stage_wear_ = start_.stage_wear();
  return start_cost;
}

SimulatedAnnealingSolver::PolishResult SimulatedAnnealingSolver::polish_best(const OcpProblem& problem,
                                                                             const Deadline& deadline,
                                                                             const BudgetPlan& plan,
                                                                             Duration full_rollout,
                                                                             Duration longest_proposal, Solution* out,
                                                                             long* rollouts) noexcept {
  // The polish's own stop keeps the annealing's slack; its line search starts from the slowest
  // proposal seen as the price of a full rollout, and raises it by what its trials take.
  const TimePoint polish_end = deadline.at() == TimePoint::max() ? deadline.at() : deadline.at() - full_rollout;
  const Duration proposal = std::max(full_rollout, longest_proposal);
  PolishResult result;
  result.exact = plan.exact_polish;
  int steps = result.exact ? polish(problem, deadline, polish_end, proposal, out, rollouts) : kGradientDoesNotFit;
  // The first solve learns a gradient's time from one stage; when it does not fit, or whenever
  // none would, the knot polish takes the window.
  if (steps == kGradientDoesNotFit && plan.knot_polish_allowed) {
    result.exact = false;
    steps = knot_polish(problem, deadline, polish_end, proposal, out, rollouts);
  }
  result.polished = steps > 0;
  return result;
}

const char* SimulatedAnnealingSolver::solve_reason(bool deadline_hit, const PolishResult& polish) noexcept {
  if (deadline_hit) {
    return !polish.polished ? "stopped at the deadline with the best plan seen"
           : polish.exact   ? "annealed and polished until the deadline"
                            : "annealed and polished over the knots until the deadline";
  }
  return !polish.polished ? "completed the annealing schedule"
         : polish.exact   ? "completed the annealing schedule and the polish"
                          : "completed the annealing schedule and the knot polish";
}

SolveStatus SimulatedAnnealingSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses,
                                               Deadline deadline, Solution* out, SolveSummary* summary) noexcept {
  const WorkerPool::Solving solving(workers_.get());
  const double start_cost = start_from_guesses(problem, guesses, deadline);
  long rollouts = start_.rollouts();
  if (!std::isfinite(start_cost)) {
    summary->reason = "the model failed on every initial guess";
    summary->rollouts = rollouts;
    return SolveStatus::kNumericalError;
  }
  double current_cost = start_cost;
  // A full rollout, as timed on the start's guesses; the loop stops while one more proposal (the
  // slowest seen) and one such rollout of slack for the scheduler still fit before the deadline.
  const auto full_rollout = start_.longest_rollout();
  const auto loop_start = deadline.now();
  const BudgetPlan plan = plan_budget(deadline, loop_start, full_rollout);
  summary->initial_cost = current_cost;
  out->inputs = inputs_;
  out->states = states_;
  best_stage_wear_ = stage_wear_;
  best_stage_costs_ = stage_costs_;
  double best_cost = current_cost;

  // Geometric cooling over the schedule's progress: the larger of the share of iterations done and
  // the share of the time budget used, so a deadline-limited solve still cools all the way.
  Schedule schedule;
  schedule.calibration_cost = current_cost;
  double progress_at_reheat = 0.0;
  int window_proposed = 0, window_accepted = 0;
  int iteration = 0;
  bool deadline_hit = false;

  auto longest_proposal = full_rollout;  // grows if a proposal ever takes longer than a full rollout
  auto now = deadline.now();
  for (; iteration < options_.max_iterations; ++iteration) {
    const auto proposal_start = now;
    // Room for one more proposal and one rollout's worth of slack for the scheduler (measured
    // overruns without it: up to 0.2 ms on a 20 ms budget). The slowest proposal, not the start's
    // rollout: a plan that slows under 0.25 m/s takes the slow-motion substeps, and its rollout
    // costs ~10x one in cruise.
    if (proposal_start + longest_proposal + full_rollout >= plan.anneal_end) {
      deadline_hit = true;
      break;
    }
    const double time_progress =
        plan.loop_budget > 0.0 ? std::chrono::duration<double>(proposal_start - loop_start).count() / plan.loop_budget
                               : 1.0;
    const double progress =
        std::max(static_cast<double>(iteration) / options_.max_iterations, time_progress) - progress_at_reheat;
    double candidate_cost = 0.0;
    if (!evaluate_batch(problem, &rollouts, &candidate_cost)) {
      now = deadline.now();
      continue;
    }
    now = deadline.now();
    longest_proposal = std::max(longest_proposal, now - proposal_start);
    // A uniform draw only where the acceptance test needs one (calibrated, uphill): the seed's
    // sequence of draws depends on it.
    const double delta = candidate_cost - current_cost;
    const bool needs_draw = schedule.probes >= kProbeMoves && delta > 0.0 && std::isfinite(delta);
    const bool accept = schedule.accepts(delta, progress, options_.initial_acceptance,
                                         options_.final_temperature_ratio, needs_draw ? random_.uniform() : 0.0);
    ++window_proposed;
    if (accept) {
      ++window_accepted;
      take_candidate(candidate_cost, &current_cost, &best_cost, out);
    }
    if (window_proposed >= options_.adapt_interval) {
      const double rate = static_cast<double>(window_accepted) / window_proposed;
      const double factor = rate > options_.target_acceptance ? 1.25 : 0.8;
      sigma_ = (sigma_ * factor).cwiseMax(1e-6 * reference_step_).cwiseMin(2.0 * reference_step_);
      window_proposed = window_accepted = 0;
    }
    if (options_.reheat_interval > 0 && iteration > 0 && iteration % options_.reheat_interval == 0) {
      current_cost = restart_from_best(problem, *out);
      ++rollouts;
      now = deadline.now();
      // Warmer again: half of the way back up the schedule.
      progress_at_reheat += 0.5 * std::max(0.0, progress);
    }
  }
  out->cost = best_cost;
  const PolishResult polished =
      plan.polishing ? polish_best(problem, deadline, plan, full_rollout, longest_proposal, out, &rollouts) : PolishResult{};
  summary->iterations = iteration;
  summary->rollouts = rollouts;
  summary->cost = problem.breakdown(out->inputs, out->states, best_stage_wear_);
  summary->reason = solve_reason(deadline_hit, polished);
  return deadline_hit ? SolveStatus::kBudgetExhausted : SolveStatus::kConverged;
}

}  // namespace swerve
