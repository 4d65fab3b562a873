#include "swerve/solvers/nlopt_solver.hpp"

#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

#include "swerve/core/config_error.hpp"
#include "swerve/ocp/ocp_derivatives.hpp"

namespace swerve {
namespace {

struct AlgorithmName {
  const char* name;
  nlopt::algorithm algorithm;
  bool gradient;         // needs the exact gradient (LD_*)
  bool linear_rows;      // takes the per-step change bounds as inequality constraints
};
constexpr AlgorithmName kAlgorithms[] = {{"LD_SLSQP", nlopt::LD_SLSQP, true, true},
                                         {"LD_MMA", nlopt::LD_MMA, true, true},
                                         {"LD_CCSAQ", nlopt::LD_CCSAQ, true, true},
                                         {"LD_LBFGS", nlopt::LD_LBFGS, true, false},
                                         {"LN_BOBYQA", nlopt::LN_BOBYQA, false, false},
                                         {"LN_COBYLA", nlopt::LN_COBYLA, false, false},
                                         {"LN_SBPLX", nlopt::LN_SBPLX, false, false},
                                         {"LN_NELDERMEAD", nlopt::LN_NELDERMEAD, false, false}};

// NloptOptions::fields() lists the same names: validate() has refused any other before a solver is built.
const AlgorithmName* find_algorithm(const std::string& name) {
  for (const AlgorithmName& a : kAlgorithms) {
    if (name == a.name) return &a;
  }
  return nullptr;
}

// A bound NLopt can hold: infinite boxes become large finite ones (BOBYQA needs finite bounds).
constexpr double kLargeBound = 1e6;

}  // namespace

// What the objective needs: the problem, the deadline, buffers, and the best point seen.
struct NloptSolver::Evaluation {
  const OcpProblem* problem = nullptr;
  PredictionData* data = nullptr;         // the model's scratch (Solver::model_data)
  OcpDerivatives* derivatives = nullptr;  // gradient algorithms only
  Eigen::MatrixXd gradient;               // nu x N
  Deadline deadline;
  Eigen::MatrixXd inputs, states, best_inputs, best_states;  // nu x N, nx x N+1
  Eigen::VectorXd stage_costs;                               // N
  double best_cost = std::numeric_limits<double>::infinity();
  long evaluations = 0;
  bool deadline_hit = false;
  Duration longest{};  // the longest evaluation so far

  // Derivative-free: f(x) is the cost of the projected input sequence. Gradient algorithms: the
  // cost of x itself and its exact gradient (adjoint), as their bounds and constraints keep x
  // feasible; only feasible points can become the best. NaN-free (a failed rollout costs +huge).
  static double objective(unsigned n, const double* x, double* gradient, void* data) {
    auto* self = static_cast<Evaluation*>(data);
    // Room for this evaluation, the final one in do_solve and one more of slack (as SA does).
    const TimePoint start = self->deadline.now();
    if (start + 3 * self->longest >= self->deadline.at()) {
      self->deadline_hit = true;
      throw nlopt::forced_stop();
    }
    std::copy(x, x + n, self->inputs.data());
    double cost = 0.0;
    bool feasible = true;
    if (self->derivatives != nullptr) {
      feasible = self->problem->is_feasible(self->inputs, 1e-9);
      cost = gradient != nullptr
                 ? self->derivatives->cost_and_gradient(*self->problem, self->inputs, self->states, self->gradient)
                 : self->problem->rollout(*self->data, self->inputs, 0, self->states, self->stage_costs);
      if (gradient != nullptr) {
        if (std::isfinite(cost)) {
          std::copy(self->gradient.data(), self->gradient.data() + n, gradient);
        } else {
          std::fill(gradient, gradient + n, 0.0);
        }
      }
    } else {
      self->problem->project(self->inputs);
      cost = self->problem->rollout(*self->data, self->inputs, 0, self->states, self->stage_costs);
    }
    self->longest = std::max(self->longest, self->deadline.now() - start);
    ++self->evaluations;
    if (!std::isfinite(cost)) return std::numeric_limits<double>::max();
    if (feasible && cost < self->best_cost) {
      self->best_cost = cost;
      self->best_inputs = self->inputs;
      self->best_states = self->states;
    }
    return cost;
  }

  // The per-step change bounds as 2 rows per bounded input and step: +-(u_k - u_{k-1}) <= max_step.
  static void step_rows(unsigned m, double* result, unsigned n, const double* x, double* jacobian, void* data) {
    auto* self = static_cast<Evaluation*>(data);
    const OcpProblem& problem = *self->problem;
    const int nu = problem.input_size();
    const Eigen::VectorXd& max_step = problem.bounds().max_step;
    if (jacobian != nullptr) std::fill(jacobian, jacobian + static_cast<std::size_t>(m) * n, 0.0);
    unsigned row = 0;
    for (int k = 0; k < problem.horizon(); ++k) {
      for (int i = 0; i < nu; ++i) {
        if (!std::isfinite(max_step[i])) continue;
        const unsigned column = static_cast<unsigned>(k * nu + i);
        const double before = k == 0 ? problem.previous_input()[i] : x[column - static_cast<unsigned>(nu)];
        const double change = x[column] - before;
        result[row] = change - max_step[i];
        result[row + 1] = -change - max_step[i];
        if (jacobian != nullptr) {
          jacobian[row * n + column] = 1.0;
          jacobian[(row + 1) * n + column] = -1.0;
          if (k > 0) {
            jacobian[row * n + column - static_cast<unsigned>(nu)] = -1.0;
            jacobian[(row + 1) * n + column - static_cast<unsigned>(nu)] = 1.0;
          }
        }
        row += 2;
      }
    }
  }
};

NloptSolver::NloptSolver(const OcpProblem& problem, NloptOptions options)
    : Solver(problem), options_(std::move(options)), nx_(problem.state_size()), nu_(problem.input_size()), horizon_(problem.horizon()),
      start_(problem), evaluation_(std::make_unique<Evaluation>()) {
  options_.validate();
  const auto size = static_cast<std::size_t>(nu_ * horizon_);
  x_.resize(size);
  lower_.resize(size);
  upper_.resize(size);
  step_.resize(size);
  evaluation_->inputs = evaluation_->best_inputs = Eigen::MatrixXd::Zero(nu_, horizon_);
  evaluation_->states = evaluation_->best_states = Eigen::MatrixXd::Zero(nx_, horizon_ + 1);
  evaluation_->stage_costs = Eigen::VectorXd::Zero(horizon_);
  evaluation_->gradient = Eigen::MatrixXd::Zero(nu_, horizon_);
  const AlgorithmName& algorithm = *find_algorithm(options_.algorithm);
  if (algorithm.gradient) {
    derivatives_ = std::make_unique<OcpDerivatives>(problem);  // ConfigError without model Jacobians
    evaluation_->derivatives = derivatives_.get();
  }
  if (algorithm.linear_rows) {
    for (int i = 0; i < nu_; ++i) {
      if (std::isfinite(problem.bounds().max_step[i])) step_row_count_ += 2 * static_cast<unsigned>(horizon_);
    }
    step_row_tolerances_.assign(step_row_count_, 1e-10);
  }
}

NloptSolver::~NloptSolver() = default;

namespace {

// The status and reason of a run NLopt ended with `result` (the best point seen is the answer).
SolveStatus status_of(nlopt::result result, SolveSummary* summary) noexcept {
  switch (result) {
    case nlopt::SUCCESS:
    case nlopt::STOPVAL_REACHED:
    case nlopt::FTOL_REACHED:
    case nlopt::XTOL_REACHED:
      summary->reason = "nlopt converged (tolerance reached)";
      return SolveStatus::kConverged;
    case nlopt::MAXEVAL_REACHED:
      summary->reason = "nlopt stopped at max_evaluations with the best point seen";
      return SolveStatus::kBudgetExhausted;
    case nlopt::MAXTIME_REACHED:
    case nlopt::FORCED_STOP:
      summary->reason = "nlopt stopped at the deadline with the best point seen";
      return SolveStatus::kBudgetExhausted;
    case nlopt::ROUNDOFF_LIMITED:
      summary->reason = "nlopt stopped by round-off with the best point seen";
      return SolveStatus::kBudgetExhausted;
    default:
      if (summary->reason == nullptr || std::string(summary->reason) == "solve() not called") {
        summary->reason = "nlopt failed with the best point seen";
      }
      return SolveStatus::kBudgetExhausted;
  }
}

}  // namespace

SolveStatus NloptSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline,
                                  Solution* out, SolveSummary* summary) noexcept {
  Evaluation& e = *evaluation_;
  e.problem = &problem;
  e.data = &model_data();
  e.deadline = deadline;
  e.evaluations = 0;
  e.deadline_hit = false;
  const double start_cost = start_.choose(problem, guesses, deadline);
  e.best_inputs = start_.inputs();
  e.best_states = start_.states();
  e.longest = start_.longest_rollout();
  if (e.derivatives != nullptr) e.longest *= kJacobianRolloutCost;  // an evaluation with the gradient
  Eigen::MatrixXd::Map(x_.data(), nu_, horizon_) = e.best_inputs;
  e.best_cost = start_cost;  // nothing worse than the start comes back
  summary->initial_cost = start_cost;
  const InputBounds& bounds = problem.bounds();
  for (int k = 0; k < horizon_; ++k) {
    for (int i = 0; i < nu_; ++i) {
      const auto j = static_cast<std::size_t>(k * nu_ + i);
      lower_[j] = bounds.lower.size() == nu_ ? std::max(-kLargeBound, bounds.lower[i]) : -kLargeBound;
      upper_[j] = bounds.upper.size() == nu_ ? std::min(kLargeBound, bounds.upper[i]) : kLargeBound;
      const double half_range = 0.5 * (upper_[j] - lower_[j]);
      step_[j] = options_.initial_step_fraction * std::min(half_range, 1.0);
      x_[j] = std::clamp(x_[j], lower_[j], upper_[j]);
    }
  }
  nlopt::result result = nlopt::FAILURE;
  try {
    nlopt::opt opt(find_algorithm(options_.algorithm)->algorithm, static_cast<unsigned>(x_.size()));
    opt.set_lower_bounds(lower_);
    opt.set_upper_bounds(upper_);
    opt.set_min_objective(&Evaluation::objective, &e);
    if (step_row_count_ > 0) opt.add_inequality_mconstraint(&Evaluation::step_rows, &e, step_row_tolerances_);
    opt.set_xtol_rel(options_.xtol_rel);
    opt.set_ftol_rel(options_.ftol_rel);
    opt.set_maxeval(options_.max_evaluations);
    opt.set_initial_step(step_);
    // NLopt's own time limit backs up the objective's deadline check on the steady clock only.
    if (deadline.on_steady_clock()) opt.set_maxtime(std::max(1e-6, to_seconds(deadline.remaining())));
    double minimum = 0.0;
    result = opt.optimize(x_, minimum);
  } catch (const nlopt::forced_stop&) {
    result = nlopt::FORCED_STOP;
  } catch (const nlopt::roundoff_limited&) {
    result = nlopt::ROUNDOFF_LIMITED;  // the best point so far is still a usable plan
  } catch (const std::bad_alloc&) {
    summary->reason = "nlopt: out of memory";
    return SolveStatus::kNumericalError;
  } catch (const std::invalid_argument&) {
    summary->reason = "nlopt rejected its arguments (bounds or options)";
    return SolveStatus::kInvalidInput;
  } catch (const std::exception&) {
    summary->reason = "nlopt failed (generic failure)";
    result = nlopt::FAILURE;
  }
  if (e.derivatives != nullptr) {
    // The gradient algorithm's last point, projected (its constraints hold only to a tolerance).
    e.inputs = Eigen::MatrixXd::Map(x_.data(), nu_, horizon_);
    problem.project(e.inputs);
    const double cost = problem.rollout(*e.data, e.inputs, 0, e.states, e.stage_costs);
    if (cost < e.best_cost) {
      e.best_cost = cost;
      e.best_inputs = e.inputs;
      e.best_states = e.states;
    }
  }
  summary->iterations = static_cast<int>(std::min<long>(e.evaluations, std::numeric_limits<int>::max()));
  summary->rollouts = e.evaluations;
  if (!std::isfinite(e.best_cost)) {
    // Not one evaluation finished: the initial point stands if it was usable.
    e.best_inputs = Eigen::MatrixXd::Map(x_.data(), nu_, horizon_);
    problem.project(e.best_inputs);
    e.best_cost = problem.rollout(*e.data, e.best_inputs, 0, e.best_states, e.stage_costs);
    if (!std::isfinite(e.best_cost)) {
      summary->reason = "the model failed on the initial point";
      return SolveStatus::kNumericalError;
    }
  }
  out->inputs = e.best_inputs;
  out->states = e.best_states;
  out->cost = e.best_cost;
  summary->cost = problem.evaluate(*e.data, out->inputs, e.states);
  return status_of(result, summary);
}

}  // namespace swerve
