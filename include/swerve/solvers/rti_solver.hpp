// The real-time iteration backend (Diehl, Bock & Schloeder, "A real-time iteration scheme for
// nonlinear optimization in optimal feedback control", SIAM J. Control Optim. 43(5), 2005): per
// cycle one Gauss-Newton SQP step from the shifted plan, rather than an optimisation to
// convergence, so its cost per cycle is fixed and small. Allocation-free after construction.
//
// One iteration: the exact stage Jacobians along the plan's rollout (OcpDerivatives), the
// condensed Gauss-Newton Hessian over the inputs (CondensedGaussNewton) with a Levenberg damping
// that adapts to how well the model predicted the last step, its quadratic program under the input
// boxes and per-step change bounds (BoundedInputQp, an interior point), and a backtracking line
// search on the true cost along the step, so no step makes the plan worse. Condensed rather than
// stage-wise (Riccati) because this problem has few inputs and many states (nu = 3 body-twist
// inputs, nx up to 36 on the 10-module vehicle): see docs/decisions/rti.md.
//
// With max_iterations > 1 it is a damped Gauss-Newton SQP run to convergence (the conformance suite
// uses it so), stopped by the deadline like every backend.
//
// Preparation and feedback: prepare() on the next cycle's problem with its predicted start
// linearises and condenses before the measurement arrives; the solve() that follows on the measured
// start moves the prepared gradient by the Gauss-Newton cross term (CondensedGaussNewton::
// start_product), so its first iteration is the QP and the line search's rollouts alone.
#pragma once

#include <memory>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

struct RtiOptions {
  int max_iterations = 1;          // SQP iterations per solve: 1 is the real-time iteration
  // Converged when a QP step predicts a decrease below tolerance x (1 + |cost|), or an accepted step
  // decreased the cost by less than that.
  double tolerance = 1e-9;
  double qp_tolerance = 1e-9;      // the interior point's scaled KKT residuals
  int qp_max_iterations = 50;
  int line_search_steps = 8;       // step halvings tried before a step is refused; 0: full steps only
  // The Levenberg damping's floor, added to the Hessian's diagonal (per squared input unit); the
  // damping grows tenfold after a refused step and falls threefold after a full step the model
  // predicted well, and is carried from one solve to the next.
  double damping = 1e-6;
  bool wear_curvature = true;      // the wear's generalised Gauss-Newton curvature (else gradient only)
  // The curvature Gauss-Newton leaves out (the wear's and the dynamics' second derivatives), learnt
  // per stage from successive linearisations by damped BFGS and carried across solves
  // (StageQuasiNewton). Off: the Gauss-Newton Hessian alone.
  bool stage_quasi_newton = true;
  // Whether prepare() prepares: a caller that prepares between cycles (Controller::prepare) then
  // gets a feedback in place of a whole first iteration. Off: every solve is whole.
  bool prepare = true;
  static const OptionFields<RtiOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;                             // ConfigError naming the field and value
};

class RtiSolver final : public Solver {
 public:
  // Sizes every buffer for the problem's shape; throws ConfigError on bad options or a model
  // without exact Jacobians.
  RtiSolver(const OcpProblem& problem_shape, RtiOptions options);
  ~RtiSolver() override;
  const char* name() const noexcept override { return "rti"; }
  const RtiOptions& options() const noexcept { return options_; }

  // What only this backend reports about its last solve.
  struct Details {
    int qp_iterations = 0;        // interior-point iterations, summed over the solve's QPs
    int line_search_steps = 0;    // halvings taken, summed
    double damping = 0.0;         // the Levenberg damping the next solve starts with
    double step_fraction = 0.0;   // of the last step: 1 full, < 1 shortened, 0 refused
    bool feedback = false;        // the solve began from a preparation (its first iteration was not linearised)
  };
  const Details& last_details() const noexcept { return details_; }
  void forget_preparation() noexcept override;
  bool has_preparation() const noexcept override { return options_.prepare; }

  struct Impl;  // buffers, the linearisation, the condensing and the QP (defined in the source)

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override;
  bool do_prepare(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline) noexcept override;

  RtiOptions options_;
  std::unique_ptr<Impl> impl_;
  Details details_;
};

}  // namespace swerve
