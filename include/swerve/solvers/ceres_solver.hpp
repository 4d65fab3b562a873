// The Ceres backend (libceres-dev): the OCP as a bounded nonlinear least-squares problem over the
// input sequence, solved by Levenberg-Marquardt with exact Jacobians, under the wall-clock deadline.
// It starts from the best initial guess and never returns anything worse than that start.
//
// Why single shooting: the inputs u_0..u_{N-1} are the only unknowns and the states come from
// rolling them out, so every iterate obeys the exact dynamics (no defect constraints, which Ceres
// could only hold as penalties) and the problem stays small: N dense blocks of nu inputs. The
// residual Jacobian is dense lower block-triangular and comes from forward sensitivities over the
// model's exact per-step Jacobians (OcpDerivatives, ceres::Jet inside the model).
//
// Residuals of stage k, so that 1/2 |r|^2 = the OcpProblem cost + N * kWearSmoothing^2:
//   sqrt(2 scale Q) (pose(x_{k+1}) - ref), heading wrapped   (scale = terminal_scale at k = N-1)
//     (times the pseudo-Huber factor beyond weights.pose_huber_width: OcpProblem::tracking_residuals)
//   sqrt(2 Qv) (twist(x_{k+1}) - ref)
//   sqrt(2 (lambda W_k + eps^2))                              (eps = kWearSmoothing keeps it smooth at W = 0)
//   sqrt(2 R) u_k,  sqrt(2 S) (u_k - u_{k-1})                 (u_{-1}: the previous cycle's input)
//   sqrt(2 step_penalty_weight) max(0, |u_k - u_{k-1}| - max_step)
// The input boxes are Ceres parameter bounds. Ceres has no general linear constraints, so the
// per-step change bounds are a penalty that is zero on every feasible plan: it keeps the iterates
// near feasible, and the answer is projected onto the bounds (OcpProblem::project) before it is
// compared with the start.
//
// Deadline: Ceres gets the time left minus twice one Jacobian evaluation (timed at the start, kept
// back for the wrap-up), an iteration callback stops it when the next iteration would not fit, and
// trial-point evaluations are refused past that point, which ends an iteration at once.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

struct CeresOptions {
  int max_iterations = 100;                // Ceres iterations (successful and unsuccessful steps)
  double function_tolerance = 1e-10;       // relative cost decrease that counts as converged
  double gradient_tolerance = 1e-10;       // max-norm of the projected gradient
  double parameter_tolerance = 1e-10;      // relative step size
  std::string linear_solver = "dense_qr";  // dense_qr | dense_normal_cholesky
  double step_penalty_weight = 1e4;        // on violations of the per-step change bounds
  // The rules, read by the YAML loader too; defined in this header, so a build without the Ceres
  // backend (the arm64 cross build) still loads and checks a `ceres:` block.
  static const OptionFields<CeresOptions>& fields();
  void validate() const;                   // ConfigError naming the field and value
};

inline const OptionFields<CeresOptions>& CeresOptions::fields() {
  // Ceres itself takes tolerances >= 0 (0: that test off).
  static const OptionFields<CeresOptions> table{
      {"max_iterations", &CeresOptions::max_iterations, Bound::at_least(1)},
      {"function_tolerance", &CeresOptions::function_tolerance, Bound::non_negative()},
      {"gradient_tolerance", &CeresOptions::gradient_tolerance, Bound::non_negative()},
      {"parameter_tolerance", &CeresOptions::parameter_tolerance, Bound::non_negative()},
      {"linear_solver", &CeresOptions::linear_solver, Bound::any(), {"dense_qr", "dense_normal_cholesky"}},
      {"step_penalty_weight", &CeresOptions::step_penalty_weight, Bound::non_negative()},
  };
  return table;
}

inline void CeresOptions::validate() const { check_fields("CeresOptions", *this, fields()); }

class CeresSolver final : public Solver {
 public:
  // The wear residual's smoothing eps: sqrt stays differentiable where the wear is zero.
  static constexpr double kWearSmoothing = 1e-3;

  // Builds the Ceres problem once for the problem's shape (Ceres itself allocates inside each
  // solve). Throws ConfigError on bad options or when the problem's model has no exact Jacobians.
  CeresSolver(const OcpProblem& problem_shape, CeresOptions options);
  ~CeresSolver() override;

  const char* name() const noexcept override { return "ceres"; }
  const CeresOptions& options() const noexcept { return options_; }

  // The least-squares form Ceres minimises, for tests and diagnostics. residual_count() rows;
  // `residuals` receives r(inputs) and `jacobian` (if not null, residual_count() x nu N) receives
  // [dr/du_0 ... dr/du_{N-1}]. false on a wrong size or when the model fails.
  int residual_count() const noexcept;
  bool evaluate_residuals(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                          Eigen::Ref<Eigen::VectorXd> residuals, Eigen::MatrixXd* jacobian);

  struct Impl;  // the Ceres problem, its cost function and the buffers (defined in the source)

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override;

  CeresOptions options_;
  int nx_, nu_, horizon_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace swerve
