#include "swerve/solvers/ceres_solver.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "swerve/core/config_error.hpp"
#include "swerve/ocp/ocp_derivatives.hpp"

namespace swerve {
namespace {

struct LinearSolverName {
  const char* name;
  ceres::LinearSolverType type;
};
constexpr LinearSolverName kLinearSolvers[] = {{"dense_qr", ceres::DENSE_QR},
                                               {"dense_normal_cholesky", ceres::DENSE_NORMAL_CHOLESKY}};

const LinearSolverName* find_linear_solver(const std::string& name) {
  for (const LinearSolverName& s : kLinearSolvers) {
    if (name == s.name) return &s;
  }
  return nullptr;
}

// Ceres hands over each parameter block's Jacobian as a row-major (residuals x block size) array.
using JacobianBlock = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

// Residual rows of one stage, in this order: OcpProblem's tracking residuals (pose, twist, tube),
// the wear (1), then OcpProblem's effort and rate residuals and the step penalty (nu each). Ceres'
// cost 1/2 |r|^2 is then OcpProblem's cost, with the wear as the residual sqrt(2 lambda W).
constexpr int kWearRow = OcpProblem::kTrackingResiduals;
constexpr int kEffortRow = kWearRow + 1;
// Then one row per weighted state (OcpProblem::state_effort_index).
int stage_residual_count(const OcpProblem& shape) {
  return kEffortRow + 3 * shape.input_size() + static_cast<int>(shape.state_effort_index().size());
}

// The OCP as one Ceres cost function over N parameter blocks of nu inputs: a single-shooting
// rollout that writes every stage's residuals (layout in the header) and, when Ceres asks for
// them, their Jacobians from forward sensitivities dx_k/du_j over the model's exact step Jacobians.
class ShootingResiduals final : public ceres::CostFunction {
 public:
  ShootingResiduals(const OcpProblem& shape, double step_penalty_weight)
      : nx_(shape.state_size()), nu_(shape.input_size()), horizon_(shape.horizon()),
        stage_rows_(stage_residual_count(shape)), penalty_root_(std::sqrt(2.0 * step_penalty_weight)),
        derivatives_(shape) {
    set_num_residuals(horizon_ * stage_rows_);
    mutable_parameter_block_sizes()->assign(static_cast<std::size_t>(horizon_), nu_);
    inputs_ = Eigen::MatrixXd::Zero(nu_, horizon_);
    states_ = Eigen::MatrixXd::Zero(nx_, horizon_ + 1);
    sensitivity_ = next_sensitivity_ = Eigen::MatrixXd::Zero(nx_, nu_ * horizon_);
  }

  // The problem the next evaluations are of (same shape); its residuals' weights come with it.
  void bind(const OcpProblem& problem, PredictionData& data) noexcept {
    problem_ = &problem;
    data_ = &data;
    evaluations_ = 0;
    stop_ = Deadline(TimePoint::max());
  }
  // From `stop` on, residual-only evaluations are refused (see Evaluate).
  void set_stop(Deadline stop) noexcept { stop_ = stop; }
  long evaluations() const noexcept { return evaluations_; }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    // The deadline inside an iteration: Ceres treats a failed residual-only evaluation (a trial
    // point of its line search or trust region) as a rejected step, so refusing them ends the
    // iteration at once. Evaluations with Jacobians are never refused: Ceres asks for them at a
    // point it has accepted, and a failure there makes it throw away every step it took.
    if (jacobians == nullptr && stop_.passed()) return false;
    ++evaluations_;
    const OcpProblem& problem = *problem_;
    const CostWeights& weights = problem.weights();
    const Eigen::VectorXd& max_step = problem.bounds().max_step;
    const Eigen::VectorXd& effort_root = problem.effort_root();
    const Eigen::VectorXd& rate_root = problem.rate_root();
    const int rows = num_residuals();
    for (int k = 0; k < horizon_; ++k) inputs_.col(k) = Eigen::Map<const Eigen::VectorXd>(parameters[k], nu_);
    Eigen::Map<Eigen::VectorXd> r(residuals, rows);
    if (jacobians != nullptr) {
      for (int j = 0; j < horizon_; ++j) {
        if (jacobians[j] != nullptr) JacobianBlock(jacobians[j], rows, nu_).setZero();
      }
      sensitivity_.setZero();  // dx_0/du: the initial state is fixed
    }
    states_.col(0) = problem.initial_state();
    for (int k = 0; k < horizon_; ++k) {
      // Residual-only calls (Ceres' trial points) skip the Jets: the plain step is several times cheaper.
      double wear = 0.0;
      if (jacobians != nullptr) {
        if (!derivatives_.linearize_stage(problem, k, states_.col(k), inputs_.col(k), states_.col(k + 1))) return false;
        wear = derivatives_.wear(k);
      } else if (!problem.model().step(*data_, states_.col(k), inputs_.col(k), problem.dt(), states_.col(k + 1), &wear) ||
                 !std::isfinite(wear)) {
        return false;
      }
      const int row = k * stage_rows_;
      problem.tracking_residuals(k, states_.col(k + 1), &tracking_, jacobians != nullptr ? &tracking_jacobian_ : nullptr);
      r.segment<OcpProblem::kTrackingResiduals>(row) = tracking_;
      // Wear is >= 0 physically; a model that reports less than -eps^2/lambda has no real residual.
      const double wear_square = 2.0 * (weights.wear * wear + CeresSolver::kWearSmoothing * CeresSolver::kWearSmoothing);
      if (!(wear_square > 0.0)) return false;
      const double wear_residual = std::sqrt(wear_square);
      r[row + kWearRow] = wear_residual;
      for (int i = 0; i < nu_; ++i) {
        const double u = inputs_(i, k);
        const double change = u - (k == 0 ? problem.previous_input()[i] : inputs_(i, k - 1));
        const double excess = std::abs(change) - max_step[i];  // -inf for an unbounded step
        r[row + kEffortRow + i] = effort_root[i] * u;
        r[row + kEffortRow + nu_ + i] = rate_root[i] * change;
        r[row + kEffortRow + 2 * nu_ + i] = excess > 0.0 ? penalty_root_ * excess : 0.0;
      }
      const Eigen::VectorXi& weighted_states = problem.state_effort_index();
      const Eigen::VectorXd& state_root = problem.state_effort_root();
      const int state_row = row + kEffortRow + 3 * nu_;
      for (Eigen::Index j = 0; j < weighted_states.size(); ++j) {
        r[state_row + j] = state_root[j] * states_(weighted_states[j], k + 1);
      }
      if (jacobians == nullptr) continue;

      // sensitivity_ = dx_k/du, next_sensitivity_ = dx_{k+1}/du; both zero for blocks j > k.
      derivatives_.propagate_sensitivity(k, sensitivity_, next_sensitivity_);
      const Eigen::VectorXd& wear_gradient = derivatives_.wear_gradient(k);
      const double wear_factor = weights.wear / wear_residual;  // d sqrt(2(lambda W + eps^2)) = lambda dW / r
      for (int j = 0; j <= k; ++j) {
        if (jacobians[j] == nullptr) continue;
        JacobianBlock block(jacobians[j], rows, nu_);
        const int column = j * nu_;
        block.middleRows(row, OcpProblem::kTrackingResiduals).noalias() =
            tracking_jacobian_ * next_sensitivity_.block(0, column, OcpProblem::kTrackedStates, nu_);
        block.row(row + kWearRow).noalias() =
            (wear_factor * wear_gradient.head(nx_)).transpose() * sensitivity_.middleCols(column, nu_);
        for (Eigen::Index s = 0; s < weighted_states.size(); ++s) {
          block.row(state_row + s).noalias() =
              state_root[s] * next_sensitivity_.block(weighted_states[s], column, 1, nu_);
        }
      }
      for (int i = 0; i < nu_; ++i) {
        const double change = inputs_(i, k) - (k == 0 ? problem.previous_input()[i] : inputs_(i, k - 1));
        const bool penalised = std::abs(change) > max_step[i];
        const double penalty_slope = penalised ? std::copysign(penalty_root_, change) : 0.0;
        if (jacobians[k] != nullptr) {
          JacobianBlock block(jacobians[k], rows, nu_);
          block(row + kWearRow, i) += wear_factor * wear_gradient[nx_ + i];
          block(row + kEffortRow + i, i) = effort_root[i];
          block(row + kEffortRow + nu_ + i, i) = rate_root[i];
          block(row + kEffortRow + 2 * nu_ + i, i) = penalty_slope;
        }
        if (k > 0 && jacobians[k - 1] != nullptr) {
          JacobianBlock block(jacobians[k - 1], rows, nu_);
          block(row + kEffortRow + nu_ + i, i) = -rate_root[i];
          block(row + kEffortRow + 2 * nu_ + i, i) = -penalty_slope;
        }
      }
      sensitivity_.swap(next_sensitivity_);
    }
    return true;
  }

 private:
  const OcpProblem* problem_ = nullptr;
  PredictionData* data_ = nullptr;  // the model's scratch (the solver's)
  Deadline stop_{TimePoint::max()};
  int nx_, nu_, horizon_, stage_rows_;
  double penalty_root_;  // sqrt(2 step_penalty_weight)
  // Ceres' Evaluate is const; these are its scratch space (one solve at a time, one thread).
  mutable OcpDerivatives derivatives_;
  mutable Eigen::MatrixXd inputs_, states_;                   // nu x N, nx x N+1
  mutable Eigen::MatrixXd sensitivity_, next_sensitivity_;    // nx x nu N
  mutable OcpProblem::TrackingResiduals tracking_;
  mutable OcpProblem::TrackingJacobian tracking_jacobian_;
  mutable long evaluations_ = 0;
};

// Stops Ceres when the next iteration, assumed as long as the last one, would end past `stop`.
// It returns SOLVER_TERMINATE_SUCCESSFULLY, not SOLVER_ABORT: an abort makes Ceres restore the
// parameters it started from, throwing away every step it took.
class DeadlineCallback final : public ceres::IterationCallback {
 public:
  void arm(Deadline stop) noexcept {
    stop_ = stop;
    previous_ = stop.now();
  }

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& /*summary*/) override {
    const TimePoint now = stop_.now();
    const Duration last_iteration = now - previous_;
    previous_ = now;
    return now + last_iteration >= stop_.at() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }

 private:
  Deadline stop_{};
  TimePoint previous_{};
};

}  // namespace

struct CeresSolver::Impl {
  Impl(const OcpProblem& shape, const CeresOptions& options)
      : residuals(shape, options.step_penalty_weight),
        parameters(Eigen::MatrixXd::Zero(shape.input_size(), shape.horizon())),
        problem(problem_options()),
        start(shape) {
    const int nu = shape.input_size();
    const int horizon = shape.horizon();
    const int rows = residuals.num_residuals();
    for (int k = 0; k < horizon; ++k) blocks.push_back(parameters.data() + k * nu);
    problem.AddResidualBlock(&residuals, nullptr, blocks);

    solver_options.linear_solver_type = find_linear_solver(options.linear_solver)->type;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.gradient_tolerance = options.gradient_tolerance;
    solver_options.parameter_tolerance = options.parameter_tolerance;
    // With input boxes Ceres refines each step by a projected Armijo line search; quadratic
    // interpolation needs no gradient at its trial points, so they cost a rollout, not Jacobians.
    solver_options.line_search_interpolation_type = ceres::QUADRATIC;
    solver_options.num_threads = 1;
    solver_options.minimizer_progress_to_stdout = false;
    solver_options.logging_type = ceres::SILENT;
    solver_options.callbacks.push_back(&callback);

    candidate_inputs = Eigen::MatrixXd::Zero(nu, horizon);
    candidate_states = Eigen::MatrixXd::Zero(shape.state_size(), horizon + 1);
    stage_costs = candidate_stage_wear = Eigen::VectorXd::Zero(horizon);
    residual_scratch = Eigen::VectorXd::Zero(rows);
    jacobian_scratch.assign(static_cast<std::size_t>(rows) * static_cast<std::size_t>(nu * horizon), 0.0);
    for (int k = 0; k < horizon; ++k) {
      jacobian_blocks.push_back(jacobian_scratch.data() + static_cast<std::size_t>(rows) * static_cast<std::size_t>(k * nu));
    }
  }

  static ceres::Problem::Options problem_options() {
    ceres::Problem::Options o;
    o.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // `residuals` is a member
    return o;
  }

  // The problem's input boxes as Ceres bounds; an infinite side gets Ceres' own "unbounded" value
  // (the same problem object serves problems with other bounds).
  void set_bounds(const OcpProblem& shape) {
    const InputBounds& bounds = shape.bounds();
    constexpr double kUnbounded = std::numeric_limits<double>::max();
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      for (int i = 0; i < parameters.rows(); ++i) {
        problem.SetParameterLowerBound(blocks[k], i, std::isfinite(bounds.lower[i]) ? bounds.lower[i] : -kUnbounded);
        problem.SetParameterUpperBound(blocks[k], i, std::isfinite(bounds.upper[i]) ? bounds.upper[i] : kUnbounded);
      }
    }
  }

  ShootingResiduals residuals;  // before `problem`, which refers to it
  Eigen::MatrixXd parameters;   // nu x N: column k is Ceres' parameter block k
  std::vector<double*> blocks;
  ceres::Problem problem;
  ceres::Solver::Options solver_options;
  ceres::Solver::Summary ceres_summary;
  DeadlineCallback callback;
  StartPlan start;                                // the cheapest guess, rolled out
  Eigen::MatrixXd candidate_inputs;               // nu x N: Ceres' answer, projected
  Eigen::MatrixXd candidate_states;               // nx x N+1
  Eigen::VectorXd stage_costs, candidate_stage_wear;  // N
  Eigen::VectorXd residual_scratch;                                // for timing one Evaluate
  std::vector<double> jacobian_scratch;
  std::vector<double*> jacobian_blocks;
};

CeresSolver::CeresSolver(const OcpProblem& problem_shape, CeresOptions options)
    : Solver(problem_shape), options_(std::move(options)), nx_(problem_shape.state_size()), nu_(problem_shape.input_size()),
      horizon_(problem_shape.horizon()) {
  options_.validate();
  // The table's choices name the solvers kLinearSolvers maps; a name only one list has is refused
  // here rather than dereferenced as null.
  if (find_linear_solver(options_.linear_solver) == nullptr) {
    throw_invalid_field("CeresOptions", "linear_solver", options_.linear_solver, "has no Ceres solver type");
  }
  impl_ = std::make_unique<Impl>(problem_shape, options_);
}

CeresSolver::~CeresSolver() = default;

int CeresSolver::residual_count() const noexcept { return impl_->residuals.num_residuals(); }

bool CeresSolver::evaluate_residuals(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                     Eigen::Ref<Eigen::VectorXd> residuals, Eigen::MatrixXd* jacobian) {
  if (problem.state_size() != nx_ || problem.input_size() != nu_ || problem.horizon() != horizon_ ||
      inputs.rows() != nu_ || inputs.cols() != horizon_ || residuals.size() != residual_count()) {
    return false;
  }
  const Eigen::MatrixXd contiguous = inputs;
  std::vector<const double*> parameters;
  for (int k = 0; k < horizon_; ++k) parameters.push_back(contiguous.data() + k * nu_);
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  std::vector<RowMajor> blocks(static_cast<std::size_t>(horizon_), RowMajor::Zero(residual_count(), nu_));
  std::vector<double*> block_pointers;
  for (RowMajor& block : blocks) block_pointers.push_back(block.data());
  const std::unique_ptr<PredictionData> data = problem.model().create_data();
  impl_->residuals.bind(problem, *data);
  if (!impl_->residuals.Evaluate(parameters.data(), residuals.data(), jacobian != nullptr ? block_pointers.data() : nullptr)) {
    return false;
  }
  if (jacobian != nullptr) {
    jacobian->resize(residual_count(), nu_ * horizon_);
    for (int k = 0; k < horizon_; ++k) jacobian->middleCols(k * nu_, nu_) = blocks[static_cast<std::size_t>(k)];
  }
  return true;
}

SolveStatus CeresSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline,
                                  Solution* out, SolveSummary* summary) noexcept {
  Impl& s = *impl_;
  try {
    s.residuals.bind(problem, model_data());
    const double start_cost = s.start.choose(problem, guesses, deadline);
    summary->initial_cost = start_cost;
    if (!std::isfinite(start_cost)) {
      summary->reason = "the model failed on every initial guess";
      return SolveStatus::kNumericalError;
    }
    auto return_start = [&](const char* reason) {
      out->inputs = s.start.inputs();
      out->states = s.start.states();
      out->cost = start_cost;
      summary->cost = s.start.breakdown(problem);
      summary->iterations = 0;
      summary->rollouts = s.residuals.evaluations();
      summary->reason = reason;
      return SolveStatus::kBudgetExhausted;
    };

    // One Evaluate with Jacobians costs about kJacobianRolloutCost rollouts: when even pricing one
    // would overrun the deadline, the start is the answer.
    if (deadline.now() + kJacobianRolloutCost * s.start.longest_rollout() >= deadline.at()) {
      return return_start("the deadline left no time for a Ceres iteration");
    }
    // One Evaluate with Jacobians at the start prices an iteration; twice that is kept back for
    // the projection, rollout and report after Ceres returns (and Ceres' own wrap-up).
    s.parameters = s.start.inputs();
    const TimePoint evaluate_start = deadline.now();
    const bool start_differentiable =
        s.residuals.Evaluate(s.blocks.data(), s.residual_scratch.data(), s.jacobian_blocks.data());
    const Duration evaluate_time = deadline.now() - evaluate_start;
    if (!start_differentiable) return return_start("the model's Jacobians failed at the start; returning the start");
    const Deadline stop = deadline.earlier_by(2 * evaluate_time);
    const TimePoint now = deadline.now();
    // Ceres evaluates the start again before its first step: less than that left means no step.
    if (stop.at() - now <= evaluate_time) return return_start("the deadline left no time for a Ceres iteration");

    s.set_bounds(problem);
    // Ceres' own time limit backs up the callback on the steady clock only (see the Ipopt note).
    s.solver_options.max_solver_time_in_seconds = deadline.on_steady_clock() ? to_seconds(stop.at() - now) : 1e9;
    s.callback.arm(stop);
    s.residuals.set_stop(stop);
    ceres::Solve(s.solver_options, &s.problem, &s.ceres_summary);
    const ceres::Solver::Summary& result = s.ceres_summary;

    // Ceres leaves its answer in the parameter blocks (or the start, when it failed); the step
    // penalty may leave it slightly off the change bounds, so it is projected before comparing.
    s.candidate_inputs = s.parameters;
    problem.project(s.candidate_inputs);
    const double candidate_cost = problem.rollout(model_data(), s.candidate_inputs, 0, s.candidate_states, s.stage_costs,
                                                  s.candidate_stage_wear.data());
    const bool improved = candidate_cost < start_cost;
    out->inputs = improved ? s.candidate_inputs : s.start.inputs();
    out->states = improved ? s.candidate_states : s.start.states();
    out->cost = improved ? candidate_cost : start_cost;
    summary->cost = improved ? problem.breakdown(out->inputs, out->states, s.candidate_stage_wear)
                             : s.start.breakdown(problem);
    // Ceres' iteration 0 is the evaluation of the start, not a step.
    summary->iterations = std::max(0, static_cast<int>(result.iterations.size()) - 1);
    summary->rollouts = s.residuals.evaluations();

    switch (result.termination_type) {
      case ceres::CONVERGENCE:
        summary->reason = improved ? "ceres converged (function, gradient or parameter tolerance)"
                                   : "ceres converged without improving on the start, which is returned";
        return SolveStatus::kConverged;
      case ceres::NO_CONVERGENCE:
        summary->reason = summary->iterations >= options_.max_iterations
                              ? "ceres stopped at max_iterations with its best point"
                              : "ceres stopped at its time limit with its best point";
        return SolveStatus::kBudgetExhausted;
      case ceres::USER_SUCCESS:  // the deadline callback, the only one installed
      case ceres::USER_FAILURE:  // (not returned by that callback)
        summary->reason = "ceres stopped at the deadline with its best point";
        return SolveStatus::kBudgetExhausted;
      case ceres::FAILURE:
      default:
        // Ceres restores its start on failure: the plan returned is the best initial guess.
        summary->reason = "ceres failed (model evaluation or linear solver); returning the best initial guess";
        return SolveStatus::kBudgetExhausted;
    }
  } catch (const std::bad_alloc&) {
    summary->reason = "ceres: out of memory";
  } catch (...) {
    summary->reason = "ceres threw an exception";
  }
  return SolveStatus::kNumericalError;
}

}  // namespace swerve
