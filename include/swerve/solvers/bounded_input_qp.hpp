// The quadratic program of one SQP step over an input sequence: a dense convex objective in the
// stacked inputs z = [u_0; ...; u_{N-1}] (stage by stage), each input inside its box and each
// change from one step to the next within its bound, as OcpProblem states them. Solved by
// Mehrotra's predictor-corrector primal-dual interior point (Nocedal & Wright, Numerical
// Optimization, 2nd ed., 16.6) on the normal equations, which stay dense n x n with n = nu N: every
// constraint touches one input or two consecutive ones. Sized once; solve() allocates nothing.
#pragma once

#include <Eigen/Dense>

#include <vector>

#include "swerve/ocp/ocp_problem.hpp"

namespace swerve {

class BoundedInputQp {
 public:
  struct Settings {
    double tolerance = 1e-9;  // on the scaled stationarity, primal residual and complementarity
    int max_iterations = 50;
  };
  struct Result {
    bool converged = false;
    bool not_positive_definite = false;  // the normal matrix failed to factorise: is H definite?
    int iterations = 0;
    double objective = 0.0;  // 1/2 z^T H z + q^T z at the answer
    const char* reason = "solve() not called";  // static text
  };

  // For nu inputs over N steps; throws ConfigError when either is < 1 or N > kMaxHorizon.
  BoundedInputQp(int input_size, int horizon);

  int size() const noexcept { return n_; }

  // Minimises 1/2 z^T H z + q^T z subject to bounds.lower <= u_k <= bounds.upper and
  // |u_k - u_{k-1}| <= bounds.max_step (u_{-1} = previous_input; empty or infinite entries: no
  // bound). `hessian` (n x n, symmetric, positive definite) and `linear` (n); `z` receives the
  // answer. Infeasible starts are fine (the iterates need not satisfy the bounds until the end);
  // the bounds must admit a point (they do whenever OcpProblem accepted them). Not converged
  // within max_iterations: z holds the last iterate, which may violate a bound by up to the primal
  // residual (a caller projects it). noexcept; no allocation.
  Result solve(const Eigen::Ref<const Eigen::MatrixXd>& hessian, const Eigen::Ref<const Eigen::VectorXd>& linear,
               const InputBounds& bounds, const Eigen::Ref<const Eigen::VectorXd>& previous_input,
               const Settings& settings, Eigen::Ref<Eigen::VectorXd> z) noexcept;

 private:
  // One inequality: sign (z[plus] - z[minus]) >= bound, z[minus] absent when minus < 0.
  struct Inequality {
    int plus = 0, minus = -1;
    double sign = 1.0, bound = 0.0;
  };
  void build_inequalities(const InputBounds& bounds, const Eigen::Ref<const Eigen::VectorXd>& previous_input) noexcept;
  void add_side(int plus, int minus, double lower, double upper) noexcept;
  double row_value(int i, const Eigen::Ref<const Eigen::VectorXd>& z) const noexcept;
  void add_transposed(const Eigen::VectorXd& values, Eigen::VectorXd* out) const noexcept;  // out += C^T values
  // Solves the Newton system for the complementarity residual `complementarity`; fills dz_, ds_, dl_.
  void newton_direction(const Eigen::VectorXd& complementarity) noexcept;
  double step_to_boundary() const noexcept;  // the largest step keeping s, lambda >= 0 (+inf: any)

  int nu_, horizon_, n_;
  int m_ = 0;                                // inequalities of this solve, the first m_ of rows_
  std::vector<Inequality> rows_;             // 4 n: both sides of every box and change bound
  Eigen::VectorXd slack_, multiplier_, row_residual_, complementarity_, scaled_, dual_residual_;  // m / n
  Eigen::VectorXd dz_, ds_, dl_, rhs_;
  Eigen::MatrixXd normal_;                   // n x n: H + C^T diag(lambda / s) C
  Eigen::LLT<Eigen::MatrixXd> factor_;
};

}  // namespace swerve
