// The curvature a Gauss-Newton Hessian leaves out, learnt stage by stage from gradients the
// linearisation already has. For each stage k, B_k approximates the Hessian over z = (x_k, u_k) of
// the stage's Lagrangian l_k(z) = lambda W(z) + mu_k^T F(z): the wear and the dynamics weighted by
// the stage's costate mu_k = dJ/dx_{k+1}. The condensed Hessian then adds M_k^T B_k M_k, M_k = dz/dU.
// This is the partitioned quasi-Newton update (Griewank & Toint, Numer. Math. 39, 1982), used per
// shooting interval in multiple-shooting SQP (Bock & Plitt, IFAC 1984); each B_k is updated by
// damped BFGS (Powell; Nocedal & Wright, 2nd ed., Procedure 18.2), so it stays positive
// semi-definite. W and F are the same functions at every stage and cycle (only mu differs, and the
// pair is taken at the new mu), so memory carries from one solve to the next: after a receding-
// horizon shift, stage k pairs with the last solve's stage k + 1.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "swerve/ocp/ocp_derivatives.hpp"
#include "swerve/ocp/ocp_problem.hpp"

namespace swerve {

class StageQuasiNewton {
 public:
  // Sized for the problem's shape; update() then allocates nothing.
  explicit StageQuasiNewton(const OcpProblem& shape);

  int stage_size() const noexcept { return nz_; }  // nx + nu

  // Forgets every pair and curvature (each B_k = 0).
  void reset() noexcept;
  // The next update() starts a new solve: its plan may be the last one shifted by a step, and each
  // stage pairs with whichever of the last solve's stage k or k + 1 lies nearer (summed over the
  // stages).
  void begin_solve() noexcept { new_solve_ = true; }

  // After linearised.cost_and_gradient (every stage, with its costates) along `inputs` (nu x N) and
  // their rollout `states` (nx x N+1): updates each B_k with the pair from its last linearisation
  // and remembers this one. Pairs that are too short or non-finite are skipped. With
  // `wear_curvature` (the condensed Hessian adds the wear's Gauss-Newton curvature itself), B_k
  // learns only what that leaves out: y less that curvature times s (the structured secant of
  // Dennis, Gay & Welsch, ACM TOMS 7, 1981). noexcept.
  void update(const OcpProblem& problem, const OcpDerivatives& linearised,
              const Eigen::Ref<const Eigen::MatrixXd>& states, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
              bool wear_curvature) noexcept;
  // The same for stage points z_k = (x_k, u_k) (nz x N) and any multipliers of the dynamics
  // (nx x N; e.g. a multiple-shooting solver's, with its sign and objective scaling undone) in
  // place of the single-shooting costates.
  void update_at(const OcpProblem& problem, const OcpDerivatives& linearised,
                 const Eigen::Ref<const Eigen::MatrixXd>& points, const Eigen::Ref<const Eigen::MatrixXd>& costates,
                 bool wear_curvature) noexcept;

  // B_k (nz x nz, symmetric positive semi-definite).
  const Eigen::MatrixXd& block(int k) const noexcept { return curvature_[static_cast<std::size_t>(k)]; }

  // One damped BFGS update of b with the pair (s, y); a zero b first becomes a faint multiple of the
  // identity (if s^T y > 0; else the pair is skipped). `bs`, `r`: scratch of s's size. Public for
  // its unit test.
  static void damped_bfgs(Eigen::MatrixXd* b, const Eigen::VectorXd& s, const Eigen::VectorXd& y,
                          Eigen::VectorXd* bs, Eigen::VectorXd* r) noexcept;

 private:
  // The gradient of stage k's Lagrangian at the linearisation (a, b, wear gradient) for costate mu.
  void lagrangian_gradient(double lambda, const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                           const Eigen::VectorXd& wear_gradient, const Eigen::Ref<const Eigen::VectorXd>& mu,
                           Eigen::VectorXd* gradient) const noexcept;
  // Whether the new points `points` lie nearer the remembered ones shifted by a step.
  bool shifted(const Eigen::MatrixXd& points) const noexcept;

  int horizon_, nx_, nu_, nz_;
  bool new_solve_ = true;
  // Per stage, double-buffered (this linearisation and the last): z, A, B, dW, validity, B_k.
  Eigen::MatrixXd points_, last_points_, incoming_;  // nz x N
  std::vector<Eigen::MatrixXd> a_, last_a_, b_, last_b_, curvature_, last_curvature_;
  std::vector<Eigen::VectorXd> wear_, last_wear_;
  std::vector<char> remembered_, last_remembered_;
  Eigen::VectorXd gradient_, last_gradient_, s_, y_, bs_, r_;  // nz
};

}  // namespace swerve
