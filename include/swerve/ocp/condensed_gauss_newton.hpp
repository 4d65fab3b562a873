// The Gauss-Newton model of an OcpProblem's cost over its inputs alone (single shooting,
// "condensed"): the Hessian H = sum over stages of J^T J for every least-squares residual of the
// cost (tracking, state effort, effort, rate; OcpProblem's residual form) through the forward
// sensitivities dx_k/dU, plus a curvature for the wear term, which is no sum of squares.
//
// The wear's curvature is the generalised Gauss-Newton one of a non-negative term: writing
// W_k = w_k^2 / 2, its Gauss-Newton part is grad(w_k) grad(w_k)^T = grad(W_k) grad(W_k)^T / (2 W_k),
// exact when W_k is the square of one function linear in the inputs, positive semi-definite always,
// and free: it needs only the wear's gradient, which the linearisation has. The model's own
// curvature (the dynamics' second derivatives) is left out, as in every Gauss-Newton method.
#pragma once

#include <Eigen/Core>

#include "swerve/ocp/ocp_derivatives.hpp"
#include "swerve/ocp/ocp_problem.hpp"
#include "swerve/ocp/stage_quasi_newton.hpp"

namespace swerve {

class CondensedGaussNewton {
 public:
  // A stage's wear under this (J) counts as this for its curvature grad W grad W^T / (2 W): a stage
  // that wears nothing would otherwise make its gradient's direction infinitely stiff.
  static constexpr double kWearFloor = 1e-9;
  // The factor of grad W grad W^T in a stage's wear curvature lambda grad W grad W^T / (2 W): the one
  // rule of the condensed Hessian, the learnt curvature's structured secant and Ipopt's blocks.
  static double wear_curvature_weight(double lambda, double stage_wear) noexcept {
    return lambda / (2.0 * (stage_wear > kWearFloor ? stage_wear : kWearFloor));
  }

  // Sized for the problem's shape; hessian() then allocates nothing.
  explicit CondensedGaussNewton(const OcpProblem& shape);

  int size() const noexcept { return n_; }  // nu N

  // H (nu N x nu N, stages in order, u_0 first) at the plan whose stages `linearised` holds (its
  // cost_and_gradient or linearize_stages on every stage of `states`, the rollout, nx x N+1).
  // With `wear_curvature` off, the wear term adds nothing to H. With `stage_curvature`, each
  // stage's learnt curvature B_k adds M_k^T B_k M_k (M_k = d(x_k, u_k)/dU). false on wrong sizes or
  // a non-finite result. noexcept.
  bool hessian(const OcpProblem& problem, const OcpDerivatives& linearised,
               const Eigen::Ref<const Eigen::MatrixXd>& states, bool wear_curvature,
               Eigen::Ref<Eigen::MatrixXd> hessian, const StageQuasiNewton* stage_curvature = nullptr) noexcept;

  // The same model's cross term: how its gradient over U moves with the measured start,
  // H_{U,x0} dx0 + H_{U,u_-1} du_previous (nu N, written to `product`), with the terms hessian()
  // has and at the same linearisation. The real-time iteration's feedback adds it to the gradient
  // of a plan linearised from a predicted start, so the QP of the measured start is that plan's
  // Gauss-Newton model, to first order in the start's change, without a second linearisation. One
  // forward pass of dx0 through the A_k and one adjoint pass: O(N nx^2), no sensitivity matrices.
  // `problem` holds the moved start and last input; the plan `inputs` was linearised (and rolled
  // out into `states`) from problem.initial_state() - dx0 after problem.previous_input() -
  // du_previous. With `cost_change`, also how the model predicts the plan's cost to move with the
  // start, to second order: the slope (A_0^T mu_0 + lambda dW_0/dx_0) dx0 - S (u_0 - u_-1) du_previous
  // plus half the curvature (dx0, du_previous)^T H_{start,start} (dx0, du_previous). false on wrong
  // sizes or a non-finite result. noexcept.
  bool start_product(const OcpProblem& problem, const OcpDerivatives& linearised,
                     const Eigen::Ref<const Eigen::MatrixXd>& inputs, const Eigen::Ref<const Eigen::MatrixXd>& states,
                     bool wear_curvature, const Eigen::Ref<const Eigen::VectorXd>& dx0,
                     const Eigen::Ref<const Eigen::VectorXd>& du_previous, Eigen::Ref<Eigen::VectorXd> product,
                     const StageQuasiNewton* stage_curvature = nullptr, double* cost_change = nullptr) noexcept;

 private:
  // hessian += M_k^T B_k M_k, with sensitivity_ holding dx_k/dU.
  void add_stage_curvature(int k, const Eigen::MatrixXd& curvature, Eigen::Ref<Eigen::MatrixXd> hessian) noexcept;

  int horizon_, nx_, nu_, n_;
  Eigen::MatrixXd sensitivity_, next_sensitivity_;  // nx x n: dx_k/dU and dx_{k+1}/dU
  Eigen::MatrixXd residual_jacobian_;               // rows x n: one stage's residuals' dr/dU
  Eigen::VectorXd wear_row_;                        // n: dW_k/dU
  Eigen::MatrixXd stage_map_, curved_map_;          // nz x n: M_k = d(x_k, u_k)/dU and B_k M_k
  Eigen::MatrixXd start_direction_;                 // nx x N+1: dx_k of a start change dx0
  Eigen::MatrixXd stage_terms_;                     // nz x N: the stage curvatures times (dx_k, 0)
  Eigen::VectorXd costate_direction_, costate_scratch_;  // nx
};

}  // namespace swerve
