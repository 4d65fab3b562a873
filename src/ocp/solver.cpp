#include "swerve/ocp/solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace swerve {
namespace {
class SteadyClock final : public Clock {
 public:
  TimePoint now() const noexcept override { return SolverClock::now(); }
};
const SteadyClock kSteadyClock;
}  // namespace

const Clock& steady_clock() noexcept { return kSteadyClock; }

const char* to_string(SolveStatus status) noexcept {
  switch (status) {
    case SolveStatus::kNotRun: return "not_run";
    case SolveStatus::kConverged: return "converged";
    case SolveStatus::kBudgetExhausted: return "budget_exhausted";
    case SolveStatus::kInfeasible: return "infeasible";
    case SolveStatus::kNumericalError: return "numerical_error";
    case SolveStatus::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

void Solution::resize(int state_size, int input_size, int horizon) {
  inputs = Eigen::MatrixXd::Zero(input_size, horizon);
  states = Eigen::MatrixXd::Zero(state_size, horizon + 1);
  cost = 0.0;
  valid = false;
}

void Solution::shift() noexcept {
  const Eigen::Index horizon = inputs.cols();
  if (horizon == 0) return;
  for (Eigen::Index k = 0; k + 1 < horizon; ++k) inputs.col(k) = inputs.col(k + 1);
  for (Eigen::Index k = 0; k + 1 < states.cols(); ++k) states.col(k) = states.col(k + 1);
}

namespace {

// Column k of `m` becomes m interpolated at k + whole + fraction (0 <= fraction < 1), the last
// column standing for every point past it. In place: column k reads only columns >= k.
void shift_columns(Eigen::MatrixXd& m, Eigen::Index whole, double fraction) noexcept {
  const Eigen::Index last = m.cols() - 1;
  for (Eigen::Index k = 0; k <= last; ++k) {
    const Eigen::Index from = std::min(k + whole, last);
    const Eigen::Index to = std::min(from + 1, last);
    if (fraction == 0.0 || from == to) {
      m.col(k) = m.col(from);
    } else {
      m.col(k) = (1.0 - fraction) * m.col(from) + fraction * m.col(to);
    }
  }
}

}  // namespace

void Solution::shift(double steps) noexcept {
  if (!(steps > 0.0) || !std::isfinite(steps) || inputs.cols() == 0) return;
  if (steps == 1.0) {
    shift();
    return;
  }
  const double whole = std::floor(steps);
  const double max_whole = static_cast<double>(states.cols());
  const Eigen::Index whole_steps = static_cast<Eigen::Index>(std::min(whole, max_whole));
  shift_columns(inputs, whole_steps, steps - whole);
  shift_columns(states, whole_steps, steps - whole);
}

StartPlan::StartPlan(const OcpProblem& shape)
    : inputs_(Eigen::MatrixXd::Zero(shape.input_size(), shape.horizon())),
      states_(Eigen::MatrixXd::Zero(shape.state_size(), shape.horizon() + 1)),
      candidate_inputs_(inputs_),
      candidate_states_(states_),
      stage_costs_(Eigen::VectorXd::Zero(shape.horizon())),
      stage_wear_(stage_costs_),
      candidate_stage_costs_(stage_costs_),
      candidate_stage_wear_(stage_costs_),
      workspace_(shape.model(), 1) {}

void StartPlan::try_candidate(const OcpProblem& problem, const Deadline& deadline) noexcept {
  problem.project(candidate_inputs_);
  const TimePoint rollout_start = deadline.now();
  const double cost = problem.rollout(workspace_.data(), candidate_inputs_, 0, candidate_states_, candidate_stage_costs_,
                                      candidate_stage_wear_.data());
  longest_rollout_ = std::max(longest_rollout_, deadline.now() - rollout_start);
  ++rollouts_;
  // The first candidate is kept even when its cost is not finite, so the buffers always hold a
  // plan; a later one replaces it only when it is cheaper (a NaN cost never is).
  if (!found_ || cost < cost_ || (!std::isfinite(cost_) && std::isfinite(cost))) {
    found_ = true;
    cost_ = cost;
    inputs_.swap(candidate_inputs_);
    states_.swap(candidate_states_);
    stage_costs_.swap(candidate_stage_costs_);
    stage_wear_.swap(candidate_stage_wear_);
  }
}

double StartPlan::choose(const OcpProblem& problem, const InitialGuesses& guesses, const Deadline& deadline) noexcept {
  found_ = false;
  cost_ = std::numeric_limits<double>::infinity();
  rollouts_ = skipped_ = 0;
  longest_rollout_ = Duration::zero();
  if (!workspace_.bind(problem.model())) return cost_;
  for (int g = 0; g < guesses.count; ++g) {
    const Eigen::MatrixXd* guess = guesses.sequences[g];
    if (guess == nullptr || guess->rows() != problem.input_size() || guess->cols() != problem.horizon() ||
        !guess->allFinite()) {
      continue;
    }
    if (rollouts_ > 0 && deadline.now() + 2 * longest_rollout_ >= deadline.at()) {
      ++skipped_;
      continue;
    }
    candidate_inputs_ = *guess;
    try_candidate(problem, deadline);
  }
  if (!std::isfinite(cost_)) {  // no usable guess, or the model failed on each: zero inputs
    candidate_inputs_.setZero();
    try_candidate(problem, deadline);
  }
  return cost_;
}

const char* Solver::refusal(const OcpProblem& problem, const Deadline& deadline, TimePoint start) const noexcept {
  if (problem.state_size() != state_size_ || problem.input_size() != input_size_ || problem.horizon() != horizon_) {
    return "the problem's shape differs from the one the solver was built for";
  }
  if (!problem.initial_state().allFinite() || !problem.reference_poses().allFinite() ||
      !problem.reference_twists().allFinite() || !problem.previous_input().allFinite()) {
    return "the problem's state, reference or previous input is not finite";
  }
  if (deadline.at() <= start) return "the deadline has already passed";
  return nullptr;
}

bool Solver::prepare(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline) noexcept {
  if (refusal(problem, deadline, deadline.now()) != nullptr || !workspace_.bind(problem.model())) return false;
  return do_prepare(problem, guesses, deadline);
}

SolveStatus Solver::solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                          SolveSummary* summary) noexcept {
  const TimePoint start = deadline.now();
  SolveSummary local_summary;
  SolveSummary& report = summary != nullptr ? *summary : local_summary;
  report = SolveSummary{};
  bool backend_ran = false;  // lateness is a backend's: a problem refused up front is not late
  auto finish = [&](SolveStatus status, const char* reason) {
    const TimePoint end = deadline.now();
    report.status = status;
    if (reason != nullptr) report.reason = reason;
    report.solve_time_s = to_seconds(end - start);
    report.late_s = backend_ran && end > deadline.at() ? to_seconds(end - deadline.at()) : 0.0;
    return status;
  };
  if (out == nullptr || out->inputs.rows() != problem.input_size() || out->inputs.cols() != problem.horizon() ||
      out->states.rows() != problem.state_size() || out->states.cols() != problem.horizon() + 1) {
    return finish(SolveStatus::kInvalidInput, "the output Solution is not sized for the problem");
  }
  out->valid = false;
  if (const char* refused = refusal(problem, deadline, start)) return finish(SolveStatus::kInvalidInput, refused);
  if (!workspace_.bind(problem.model())) {
    return finish(SolveStatus::kNumericalError, "out of memory for the prediction model's scratch");
  }
  const SolveStatus status = do_solve(problem, guesses, deadline, out, &report);
  backend_ran = true;
  if (has_solution(status) && (!out->inputs.allFinite() || !std::isfinite(out->cost))) {
    out->valid = false;
    return finish(SolveStatus::kNumericalError, "the backend returned a non-finite plan");
  }
  out->valid = has_solution(status);
  return finish(status, nullptr);
}

}  // namespace swerve
