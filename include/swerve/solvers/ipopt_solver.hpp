// The Ipopt backend (coinor-libipopt-dev 3.11, MUMPS): the OCP transcribed by multiple shooting,
// decision variables u_0, x_1, u_1, ..., u_{N-1}, x_N (x_0 is the measured state, a constant), the
// prediction model's step as equality constraints x_{k+1} - F(x_k, u_k) = 0 (the same discrete map
// the other backends roll out), the input boxes as variable bounds and the per-step change bounds
// as linear inequality rows. First derivatives are exact (ceres::Jet through the model, see
// OcpDerivatives). The Hessian is Ipopt's limited-memory quasi-Newton approximation. (A
// generalised Gauss-Newton Hessian, the quadratic costs' exact Hessian plus the wear term as a
// least-squares residual and no dynamics curvature, was tried and removed: on the 4-module swerve
// problem it took steps of norm ~1 into the tires' saturated region and had not converged after
// 3000 iterations, where the quasi-Newton one converged in 56 without wear and 202 with it.) The
// constraint Jacobian is block banded, its structure fixed at construction.
//
// Every solve starts from the cheapest initial guess with its rollout as the states (zero
// defects); after the first solve with a small barrier parameter (and, if asked, the previous
// multipliers shifted by one step). The deadline stops Ipopt from its intermediate callback when one more iteration would not
// fit. The plan returned is always the rollout of the final iterate's inputs (projected onto the
// bounds), so its states satisfy the dynamics exactly; it is never worse than the best guess.
#pragma once

#include <memory>
#include <string>

#include "swerve/core/option_fields.hpp"
#include "swerve/ocp/solver.hpp"

namespace swerve {

struct IpoptOptions {
  double tol = 1e-6;               // Ipopt `tol` (scaled NLP error)
  double constr_viol_tol = 1e-8;   // largest dynamics defect counted as converged
  double acceptable_tol = 1e-4;
  int max_iterations = 100;        // `max_iter`
  std::string mu_strategy = "adaptive";  // adaptive | monotone
  std::string linear_solver = "mumps";   // the one Debian's Ipopt ships
  int print_level = 0;             // 0..12
  // The Hessian of the Lagrangian Ipopt steps with. "exact": the cost's and the dynamics'
  // curvature, each stage's block by forward differences of the exact (Jet) gradients (about
  // state + input size linearisations per stage and iteration); a warm solve of the conformance
  // problem takes 3-4 iterations. "stage-quasi-newton": each stage's wear and dynamics curvature
  // learnt from the iterates by damped BFGS at Ipopt's multipliers (StageQuasiNewton, carried across
  // solves), plus the exact cost terms: one linearisation an iteration, 3.7x cheaper than "exact"
  // at 10 modules, ~2x its iterations. "limited-memory": Ipopt's L-BFGS (lbfgs_history pairs),
  // cheaper per iteration but ~200 iterations on the same problem.
  std::string hessian = "exact";
  int lbfgs_history = 6;           // `limited_memory_max_history` (hessian: limited-memory)
  // After a solve on this solver the next starts with `mu_init` = warm_mu_init (its primal start,
  // the best guess, is normally the shifted plan, near the optimum), and with the previous
  // multipliers shifted one step when warm_start_multipliers is on. With the exact Hessian both
  // pay (conformance problem, warm: 3.4 iterations against 6.1 without them); with the
  // limited-memory one the multipliers made the next solve slower (286 iterations against 161),
  // so set warm_start_multipliers: false and warm_mu_init: 1e-4 there.
  bool warm_start = true;
  bool warm_start_multipliers = true;
  double warm_mu_init = 1e-6;
  // Seconds Ipopt needs to reach its first iterate on the target (first Jacobians and
  // factorisation), if known; 0: estimated from the guesses' rollouts, then measured every solve.
  // A solve whose deadline leaves less than that and one iteration (measured too; before the
  // first, modelled from the rollout time and the Hessian's linearisations) returns its best
  // guess and lowers the estimates (the startup's by half, the iteration's by a quarter and no
  // lower than its model). An exact-Hessian iteration that would still end late is abandoned
  // between stages of its Hessian and the last iterate returned.
  double startup_estimate = 0.0;
  // The rules, read by the YAML loader too; defined in this header, so a build without the Ipopt
  // backend (the arm64 cross build: no arm64 Ipopt) still loads and checks an `ipopt:` block.
  static const OptionFields<IpoptOptions>& fields();
  void validate() const;           // ConfigError naming the field and value
};

inline const OptionFields<IpoptOptions>& IpoptOptions::fields() {
  static const OptionFields<IpoptOptions> table{
      {"tol", &IpoptOptions::tol, Bound::positive()},
      {"constr_viol_tol", &IpoptOptions::constr_viol_tol, Bound::positive()},
      {"acceptable_tol", &IpoptOptions::acceptable_tol, Bound::positive()},
      {"max_iterations", &IpoptOptions::max_iterations, Bound::at_least(1)},
      {"mu_strategy", &IpoptOptions::mu_strategy, Bound::any(), {"adaptive", "monotone"}},
      {"linear_solver", &IpoptOptions::linear_solver, Bound::any(), {"mumps"}, nullptr,
       "(the only linear solver Debian's Ipopt 3.11 is built with)"},
      {"print_level", &IpoptOptions::print_level, Bound::closed(0, 12)},
      {"hessian", &IpoptOptions::hessian, Bound::any(), {"exact", "stage-quasi-newton", "limited-memory"}},
      {"lbfgs_history", &IpoptOptions::lbfgs_history, Bound::closed(1, 100)},
      {"warm_start", &IpoptOptions::warm_start},
      {"warm_start_multipliers", &IpoptOptions::warm_start_multipliers},
      {"warm_mu_init", &IpoptOptions::warm_mu_init, Bound::positive()},
      {"startup_estimate", &IpoptOptions::startup_estimate, Bound::non_negative()},
  };
  return table;
}

inline void IpoptOptions::validate() const { check_fields("IpoptOptions", *this, fields()); }

class IpoptSolver final : public Solver {
 public:
  // Sizes the NLP for the problem's shape; throws ConfigError if the model has no Jacobians.
  IpoptSolver(const OcpProblem& problem_shape, IpoptOptions options);
  ~IpoptSolver() override;
  const char* name() const noexcept override { return "ipopt"; }
  const IpoptOptions& options() const noexcept { return options_; }
  // Forget the previous solution's multipliers (the next solve starts cold).
  void reset_warm_start() noexcept;

  // What only this backend reports about its last solve.
  struct Details {
    // Multiple shooting: the largest dynamics defect |x_{k+1} - F(x_k, u_k)| of Ipopt's final
    // iterate (+inf when it had none). The returned plan is a rollout of that iterate's inputs,
    // so its states satisfy the dynamics exactly whatever this says.
    double max_defect = 0.0;
  };
  const Details& last_details() const noexcept { return details_; }

  struct Impl;  // the Ipopt application and the TNLP (defined in the source)

 private:
  SolveStatus do_solve(const OcpProblem& problem, const InitialGuesses& guesses, Deadline deadline, Solution* out,
                       SolveSummary* summary) noexcept override;

  IpoptOptions options_;
  std::unique_ptr<Impl> impl_;
  Details details_;
};

}  // namespace swerve
