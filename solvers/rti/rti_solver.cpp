#include "swerve/solvers/rti_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_state.hpp"  // wrap_angle
#include "swerve/ocp/condensed_gauss_newton.hpp"
#include "swerve/ocp/ocp_derivatives.hpp"
#include "swerve/ocp/stage_quasi_newton.hpp"
#include "swerve/solvers/bounded_input_qp.hpp"

namespace swerve {
namespace {

// The Levenberg damping's ceiling: past it a step is as good as no step.
constexpr double kMaxDamping = 1e8;
// Armijo's sufficient-decrease share of the step's first-order decrease (Nocedal & Wright, 3.1).
constexpr double kArmijo = 1e-4;
// A full step whose actual decrease is at least this share of the model's lowers the damping.
constexpr double kGoodPrediction = 0.75;
// The damping after a shortened or refused step is at least this (per squared input unit), so a
// floor of 0 can still grow.
constexpr double kDampingAfterARefusal = 1e-6;
// Times the damping grows tenfold within one iteration while the QP's matrix is not positive definite.
constexpr int kDampingRetries = 8;


}  // namespace

const OptionFields<RtiOptions>& RtiOptions::fields() {
  static const OptionFields<RtiOptions> table{
      {"max_iterations", &RtiOptions::max_iterations, Bound::at_least(1), {}, nullptr,
       "(1: one real-time iteration per cycle)"},
      {"tolerance", &RtiOptions::tolerance, Bound::positive()},
      {"qp_tolerance", &RtiOptions::qp_tolerance, Bound::positive()},
      {"qp_max_iterations", &RtiOptions::qp_max_iterations, Bound::closed(1, 1000)},
      {"line_search_steps", &RtiOptions::line_search_steps, Bound::closed(0, 60)},
      {"damping", &RtiOptions::damping, Bound::closed(0.0, kMaxDamping)},
      {"wear_curvature", &RtiOptions::wear_curvature},
      {"stage_quasi_newton", &RtiOptions::stage_quasi_newton},
      {"prepare", &RtiOptions::prepare},
  };
  return table;
}

void RtiOptions::validate() const { check_fields("RtiOptions", *this, fields()); }

struct RtiSolver::Impl {
  explicit Impl(const OcpProblem& shape)
      : derivatives(shape), condensed(shape), quasi_newton(shape), qp(shape.input_size(), shape.horizon()),
        start(shape) {
    const int nu = shape.input_size();
    const int horizon = shape.horizon();
    const int n = nu * horizon;
    inputs = trial_inputs = step = Eigen::MatrixXd::Zero(nu, horizon);
    gradient = Eigen::MatrixXd::Zero(nu, horizon);
    states = trial_states = Eigen::MatrixXd::Zero(shape.state_size(), horizon + 1);
    stage_costs = stage_wear = trial_stage_wear = Eigen::VectorXd::Zero(horizon);
    hessian = damped = Eigen::MatrixXd::Zero(n, n);
    linear = answer = hessian_step = correction = Eigen::VectorXd::Zero(n);
    prepared_start = start_change = Eigen::VectorXd::Zero(shape.state_size());
    prepared_previous_input = previous_input_change = Eigen::VectorXd::Zero(nu);
    prepared_poses = prepared_twists = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, horizon);
    prepared_tube = Eigen::Matrix<double, 2, Eigen::Dynamic>::Zero(2, horizon);
  }

  // The plan's (inputs, states) linearisation: its gradient (the cost's, with the costates),
  // the learnt curvature's update and the condensed Hessian, in `gradient` and `hessian`. false
  // with *reason (and *status) when it fails; linearised_cost then NaN when the deadline stopped it.
  bool linearise(const OcpProblem& problem, const RtiOptions& options, const Deadline& deadline, const char** reason,
                 SolveStatus* status) noexcept {
    linearised_cost = derivatives.cost_and_gradient(problem, inputs, states, gradient, &deadline);
    if (!std::isfinite(linearised_cost)) {
      // NaN: it gave up between stages at the deadline; +inf: the model failed.
      if (std::isnan(linearised_cost)) {
        *reason = "stopped at the deadline inside a linearisation";
      } else {
        *reason = "the model's Jacobians failed on the plan";
        *status = SolveStatus::kNumericalError;
      }
      return false;
    }
    if (options.stage_quasi_newton) quasi_newton.update(problem, derivatives, states, inputs, options.wear_curvature);
    if (!condensed.hessian(problem, derivatives, states, options.wear_curvature, hessian,
                           options.stage_quasi_newton ? &quasi_newton : nullptr)) {
      *reason = "the Gauss-Newton Hessian was not finite";
      *status = SolveStatus::kNumericalError;
      return false;
    }
    return true;
  }

  // The QP of the linearised plan (`gradient`, `hessian` at `inputs`), leaving the step in `step`,
  // its first-order change g^T d in *slope and the model's decrease -(g^T d + 1/2 d^T H d) in
  // *predicted. false with *reason and *status when it fails.
  bool qp_step(const OcpProblem& problem, const RtiOptions& options, Details* details, double* slope,
               double* predicted, const char** reason, SolveStatus* status) noexcept {
    const int n = problem.input_size() * problem.horizon();
    // The QP in the new inputs z: 1/2 (z - u)^T (H + nu I) (z - u) + g^T (z - u), i.e. linear term
    // g - (H + nu I) u; its answer satisfies every bound.
    damped = hessian;
    damped.diagonal().array() += damping;
    const Eigen::Map<const Eigen::VectorXd> u(inputs.data(), n);
    const Eigen::Map<const Eigen::VectorXd> g(gradient.data(), n);
    linear = g;
    linear.noalias() -= damped * u;
    answer = u;
    BoundedInputQp::Settings settings;
    settings.tolerance = options.qp_tolerance;
    settings.max_iterations = options.qp_max_iterations;
    BoundedInputQp::Result result = qp.solve(damped, linear, problem.bounds(), problem.previous_input(), settings, answer);
    // A learnt curvature may leave H short of positive definite by its rounding: more damping then.
    for (int retry = 0; result.not_positive_definite && retry < kDampingRetries; ++retry) {
      damping = std::min(kMaxDamping, std::max(10.0 * damping, kDampingAfterARefusal));
      damped = hessian;
      damped.diagonal().array() += damping;
      linear = g;
      linear.noalias() -= damped * u;
      answer = u;
      result = qp.solve(damped, linear, problem.bounds(), problem.previous_input(), settings, answer);
    }
    details->qp_iterations += result.iterations;
    if (result.not_positive_definite) {
      *reason = "the Hessian stayed indefinite under the largest damping";
      *status = SolveStatus::kNumericalError;
      return false;
    }
    if (!answer.allFinite()) {
      *reason = "the QP's answer was not finite";
      *status = SolveStatus::kNumericalError;
      return false;
    }
    Eigen::Map<Eigen::VectorXd>(trial_inputs.data(), n) = answer;
    problem.project(trial_inputs);  // an unconverged QP may leave a bound short by its residual
    step = trial_inputs - inputs;
    const Eigen::Map<const Eigen::VectorXd> d(step.data(), n);
    *slope = g.dot(d);
    hessian_step.noalias() = hessian * d;
    *predicted = -(*slope + 0.5 * d.dot(hessian_step));
    return true;
  }

  // What a preparation assumed of the next problem besides its start: the same reference, tube
  // and wear weight (the other weights and the bounds are fixed at construction).
  void remember_preparation(const OcpProblem& problem) noexcept {
    prepared_start = problem.initial_state();
    prepared_previous_input = problem.previous_input();
    prepared_poses = problem.reference_poses();
    prepared_twists = problem.reference_twists();
    prepared_tube = problem.tube();
    prepared_wear_weight = problem.weights().wear;
    prepared = true;
  }
  // A whole solve's start: the cheapest guess (StartPlan), a new solve for the learnt curvature.
  // Returns its cost (+inf when the model failed on every guess).
  double start_from_guesses(const OcpProblem& problem, const InitialGuesses& guesses, const Deadline& deadline,
                            long* rollouts, Duration* rollout_time) noexcept {
    quasi_newton.begin_solve();
    const double cost = start.choose(problem, guesses, deadline);
    *rollouts += start.rollouts();
    *rollout_time = start.longest_rollout();
    inputs = start.inputs();
    states = start.states();
    stage_wear = start.stage_wear();
    return cost;
  }

  // The feedback's start: the prepared linearisation's gradient moved to the measured start by the
  // Gauss-Newton model's cross term, and the prepared plan's cost from the measured start predicted
  // by the same model to second order (its slope dJ/dx_0 = A_0^T mu_0 + lambda dW_0/dx_0 from the
  // costates, the rate on u_0 - u_{-1} for the last input, and its curvature along the change),
  // for feedback_line_search to judge the step by. The plan's states stay the prepared rollout
  // until a rollout from the measured start replaces them. false when the cross term was not
  // finite (a whole solve then follows).
  bool start_from_preparation(const OcpProblem& problem, const RtiOptions& options, double* estimated_cost) noexcept {
    start_change = problem.initial_state() - prepared_start;
    // The heading (state 2 of the pose every OcpProblem tracks) as the cost sees it, wrapped: a
    // prediction carries it on past pi where a measurement wraps, and the cost wraps its error.
    start_change[2] = wrap_angle(start_change[2]);
    previous_input_change = problem.previous_input() - prepared_previous_input;
    double change = 0.0;
    if (!condensed.start_product(problem, derivatives, inputs, states, options.wear_curvature, start_change,
                                 previous_input_change, correction,
                                 options.stage_quasi_newton ? &quasi_newton : nullptr, &change)) {
      return false;
    }
    Eigen::Map<Eigen::VectorXd>(gradient.data(), correction.size()) += correction;
    *estimated_cost = linearised_cost + change;
    return std::isfinite(*estimated_cost);
  }
  bool prepared_for(const OcpProblem& problem) const noexcept {
    return prepared && problem.reference_poses() == prepared_poses && problem.reference_twists() == prepared_twists &&
           problem.tube() == prepared_tube && problem.weights().wear == prepared_wear_weight;
  }

  // Backtracking along the step (Armijo): u + a d stays inside the convex bounds for a in [0, 1].
  // The accepted trial stays in trial_*; returns its fraction a, or 0 when none was accepted.
  // From step fraction 2^-first_halving on (a feedback has judged the full step already).
  double line_search(const OcpProblem& problem, PredictionData& data, const Deadline& deadline, Duration rollout_time,
                     double cost, double slope, int halvings, double* trial_cost, long* rollouts, Details* details,
                     int first_halving = 0) noexcept {
    double fraction = std::ldexp(1.0, -first_halving);
    for (int halving = first_halving; halving <= halvings; ++halving, fraction *= 0.5) {
      if (halving > 0 && deadline.now() + rollout_time >= deadline.at()) break;
      trial_inputs = inputs + fraction * step;
      *trial_cost = problem.rollout(data, trial_inputs, 0, trial_states, stage_costs, trial_stage_wear.data());
      ++*rollouts;
      if (*trial_cost <= cost + kArmijo * fraction * slope) return fraction;
      ++details->line_search_steps;
    }
    return 0.0;
  }

  // The prepared plan rolled out from the measured start (into inputs' states and stage wear):
  // its true cost, which a feedback had only estimated.
  double measure_start(const OcpProblem& problem, PredictionData& data, long* rollouts) noexcept {
    ++*rollouts;
    return problem.rollout(data, inputs, 0, states, stage_costs, stage_wear.data());
  }

  // The feedback's line search. The full step is rolled out and judged first against *cost, the
  // start's cost as the Gauss-Newton model predicts it from the start's change; only a step that
  // fails there has the start rolled out from the measured start (measure_start, *cost then its
  // true cost), against which the step is judged again and the search goes on. So a feedback that
  // the Gauss-Newton model got right costs one rollout. Returns the accepted fraction (0: none).
  double feedback_line_search(const OcpProblem& problem, PredictionData& data, const Deadline& deadline,
                              double* cost, double slope, int halvings, double* trial_cost, long* rollouts,
                              Details* details, Duration* rollout_time) noexcept {
    const TimePoint rollout_start = deadline.now();
    trial_inputs = inputs + step;
    *trial_cost = problem.rollout(data, trial_inputs, 0, trial_states, stage_costs, trial_stage_wear.data());
    *rollout_time = deadline.now() - rollout_start;
    ++*rollouts;
    if (*trial_cost <= *cost + kArmijo * slope) return 1.0;
    *cost = measure_start(problem, data, rollouts);
    if (!std::isfinite(*cost)) return 0.0;
    if (*trial_cost <= *cost + kArmijo * slope) return 1.0;
    ++details->line_search_steps;
    return line_search(problem, data, deadline, *rollout_time, *cost, slope, halvings, trial_cost, rollouts, details, 1);
  }

  // The plan (inputs, their rollout, its cost) into the solve's answer and its cost's parts.
  void hand_over(const OcpProblem& problem, double cost, Solution* out, SolveSummary* summary) const noexcept {
    out->inputs = inputs;
    out->states = states;
    out->cost = cost;
    summary->cost = problem.breakdown(inputs, states, stage_wear);
  }

  // The Levenberg damping after a step of `fraction` (0: refused) that decreased the cost by
  // `decrease` where the model predicted `predicted`.
  void adapt_damping(double floor, double fraction, double decrease, double predicted) noexcept {
    if (fraction == 1.0 && decrease >= kGoodPrediction * predicted) {
      damping = std::max(floor, damping / 3.0);
    } else if (fraction < 1.0) {
      damping = std::min(kMaxDamping, std::max(10.0 * damping, kDampingAfterARefusal));
    }
  }

  OcpDerivatives derivatives;
  CondensedGaussNewton condensed;
  StageQuasiNewton quasi_newton;
  BoundedInputQp qp;
  StartPlan start;
  // The last preparation, valid while `prepared`: what it assumed, and the change of the measured
  // start and previous input from it with the gradient's correction for them.
  bool prepared = false;
  Eigen::VectorXd prepared_start, start_change;                        // nx
  Eigen::VectorXd prepared_previous_input, previous_input_change;      // nu
  Eigen::Matrix<double, 3, Eigen::Dynamic> prepared_poses, prepared_twists;  // 3 x N
  Eigen::Matrix<double, 2, Eigen::Dynamic> prepared_tube;                    // 2 x N
  double prepared_wear_weight = 0.0;
  Eigen::VectorXd correction;                                          // nu N
  double linearised_cost = 0.0;  // of the last linearisation (a preparation's: its plan from the predicted start)
  Eigen::MatrixXd inputs, trial_inputs, step, gradient;  // nu x N
  Eigen::MatrixXd states, trial_states;                  // nx x N+1
  Eigen::VectorXd stage_costs, stage_wear, trial_stage_wear;  // N
  Eigen::MatrixXd hessian, damped;                       // nu N x nu N
  Eigen::VectorXd linear, answer, hessian_step;          // nu N
  double damping = 0.0;                                  // carried from solve to solve
  Duration iteration_estimate{};                         // zero: not yet measured
};

RtiSolver::RtiSolver(const OcpProblem& problem_shape, RtiOptions options)
    : Solver(problem_shape), options_(options) {
  options_.validate();
  impl_ = std::make_unique<Impl>(problem_shape);  // OcpDerivatives refuses a model without Jacobians
  impl_->damping = options_.damping;
}

RtiSolver::~RtiSolver() = default;

bool RtiSolver::do_prepare(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline) noexcept {
  Impl& s = *impl_;
  s.prepared = false;
  if (!options_.prepare) return false;
  long rollouts = 0;
  Duration rollout_time{};
  if (!std::isfinite(s.start_from_guesses(problem, guesses, deadline, &rollouts, &rollout_time))) return false;
  const char* reason = nullptr;
  SolveStatus status = SolveStatus::kBudgetExhausted;
  if (!s.linearise(problem, options_, deadline, &reason, &status)) return false;
  s.remember_preparation(problem);
  return true;
}

void RtiSolver::forget_preparation() noexcept { impl_->prepared = false; }

SolveStatus RtiSolver::do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline,
                                Solution* out, SolveSummary* summary) noexcept {
  Impl& s = *impl_;
  details_ = Details{};
  long rollouts = 0;
  double cost = std::numeric_limits<double>::infinity();
  Duration rollout_time{};
  if (s.prepared_for(problem)) {
    details_.feedback = s.start_from_preparation(problem, options_, &cost);
    if (details_.feedback) summary->initial_cost = cost;  // estimated, unless measured below
  }
  s.prepared = false;
  if (!details_.feedback) {
    cost = summary->initial_cost = s.start_from_guesses(problem, guesses, deadline, &rollouts, &rollout_time);
    if (!std::isfinite(cost)) {
      summary->reason = "the model failed on every initial guess";
      return SolveStatus::kNumericalError;
    }
  }
  const char* reason = "stopped at max_iterations";
  SolveStatus status = SolveStatus::kBudgetExhausted;
  int iterations = 0;
  for (; iterations < options_.max_iterations; ++iterations) {
    const TimePoint iteration_start = deadline.now();
    // The linearisation gives up between stages where one more would leave less than the QP and
    // the line search's first rollout (two rollouts' time) before the deadline, so an iteration
    // whose time is not yet known can always be tried: it ends on time either way, and is then
    // measured. (A feedback measures its first rollout in its line search.)
    const Deadline linearisation_stop = deadline.earlier_by(2 * rollout_time);
    // The feedback's iteration was linearised by the preparation: its QP and rollouts always run.
    const bool prepared_iteration = details_.feedback && iterations == 0;
    const bool known_too_slow = !prepared_iteration && s.iteration_estimate > Duration::zero() &&
                                iteration_start + s.iteration_estimate >= deadline.at();
    if (known_too_slow || (!prepared_iteration && iteration_start >= linearisation_stop.at())) {
      // Measured too slow for what is left: a quarter less is believed after a skipped solve, so a
      // budget that fits is found again after a slow cycle.
      if (known_too_slow && iterations == 0) s.iteration_estimate = s.iteration_estimate * 3 / 4;
      reason = iterations == 0 ? "the deadline left no time for an iteration; returning the start"
                               : "stopped at the deadline";
      break;
    }
    double slope = 0.0, predicted = 0.0;
    const bool stepped = prepared_iteration
                             ? s.qp_step(problem, options_, &details_, &slope, &predicted, &reason, &status)
                             : s.linearise(problem, options_, linearisation_stop, &reason, &status) &&
                                   s.qp_step(problem, options_, &details_, &slope, &predicted, &reason, &status);
    if (!stepped) {
      // A feedback returns the prepared plan as it runs from the measured start.
      if (prepared_iteration) cost = summary->initial_cost = s.measure_start(problem, model_data(), &rollouts);
      // Given up inside the linearisation: the whole iteration, extrapolated from its stages.
      const int done = s.derivatives.completed_stages();
      if (!prepared_iteration && done > 0 && done < problem.horizon()) {
        const Duration whole = (deadline.now() - iteration_start) * problem.horizon() / done + 2 * rollout_time;
        s.iteration_estimate = updated_estimate(s.iteration_estimate, whole);
      }
      break;
    }
    if (!(predicted > options_.tolerance * (1.0 + std::abs(cost))) || slope >= 0.0) {
      // A feedback returns the prepared plan as it runs from the measured start.
      if (prepared_iteration) cost = summary->initial_cost = s.measure_start(problem, model_data(), &rollouts);
      reason = "converged: the Gauss-Newton step predicts no decrease";
      status = std::isfinite(cost) ? SolveStatus::kConverged : SolveStatus::kNumericalError;
      details_.step_fraction = 0.0;
      ++iterations;
      break;
    }
    double trial_cost = cost;
    const double fraction =
        prepared_iteration
            ? s.feedback_line_search(problem, model_data(), deadline, &cost, slope, options_.line_search_steps,
                                     &trial_cost, &rollouts, &details_, &rollout_time)
            : s.line_search(problem, model_data(), deadline, rollout_time, cost, slope, options_.line_search_steps,
                            &trial_cost, &rollouts, &details_);
    if (prepared_iteration) summary->initial_cost = cost;
    s.adapt_damping(options_.damping, fraction, cost - trial_cost, predicted);
    details_.step_fraction = fraction;
    // A whole iteration's time (the feedback's lacks its linearisation).
    if (!prepared_iteration) {
      s.iteration_estimate = updated_estimate(s.iteration_estimate, deadline.now() - iteration_start);
    }
    if (fraction == 0.0) continue;  // refused: the next iteration tries again, more damped
    const double decrease = cost - trial_cost;
    s.inputs.swap(s.trial_inputs);
    s.states.swap(s.trial_states);
    s.stage_wear.swap(s.trial_stage_wear);
    cost = trial_cost;
    if (fraction == 1.0 && decrease <= options_.tolerance * (1.0 + std::abs(cost))) {
      reason = "converged: a full step decreased the cost by less than the tolerance";
      status = SolveStatus::kConverged;
      ++iterations;
      break;
    }
  }
  details_.damping = s.damping;
  s.hand_over(problem, cost, out, summary);
  summary->iterations = iterations;
  summary->rollouts = rollouts;
  summary->reason = reason;
  return status;
}

}  // namespace swerve
