#include "swerve/ocp/condensed_gauss_newton.hpp"

#include <Eigen/Dense>

#include <utility>

namespace swerve {

CondensedGaussNewton::CondensedGaussNewton(const OcpProblem& shape)
    : horizon_(shape.horizon()), nx_(shape.state_size()), nu_(shape.input_size()), n_(nu_ * horizon_) {
  sensitivity_ = next_sensitivity_ = Eigen::MatrixXd::Zero(nx_, n_);
  const auto rows = static_cast<Eigen::Index>(OcpProblem::kTrackingResiduals) + shape.state_effort_index().size();
  residual_jacobian_ = Eigen::MatrixXd::Zero(rows, n_);
  wear_row_ = Eigen::VectorXd::Zero(n_);
  stage_map_ = curved_map_ = Eigen::MatrixXd::Zero(nx_ + nu_, n_);
}

bool CondensedGaussNewton::hessian(const OcpProblem& problem, const OcpDerivatives& linearised,
                                   const Eigen::Ref<const Eigen::MatrixXd>& states, bool wear_curvature,
                                   Eigen::Ref<Eigen::MatrixXd> hessian,
                                   const StageQuasiNewton* stage_curvature) noexcept {
  if (problem.horizon() != horizon_ || problem.state_size() != nx_ || problem.input_size() != nu_ ||
      linearised.horizon() != horizon_ || states.rows() != nx_ || states.cols() != horizon_ + 1 ||
      hessian.rows() != n_ || hessian.cols() != n_ ||
      problem.state_effort_index().size() + OcpProblem::kTrackingResiduals != residual_jacobian_.rows() ||
      (stage_curvature != nullptr && stage_curvature->stage_size() != nx_ + nu_)) {
    return false;
  }
  hessian.setZero();
  sensitivity_.setZero();  // dx_0/dU = 0: the initial state is measured
  const double lambda = problem.weights().wear;
  const Eigen::Index effort_rows = problem.state_effort_index().size();
  OcpProblem::TrackingResiduals residuals;
  OcpProblem::TrackingJacobian tracking_jacobian;
  for (int k = 0; k < horizon_; ++k) {
    // Only the inputs up to u_k move x_{k+1}: the first (k + 1) nu columns.
    const Eigen::Index moving = static_cast<Eigen::Index>(k + 1) * nu_;
    linearised.propagate_sensitivity(k, sensitivity_, next_sensitivity_);
    if (wear_curvature && lambda > 0.0) {
      // dW_k/dU = dW/dx_k dx_k/dU + dW/du_k on u_k's columns.
      const Eigen::VectorXd& gradient = linearised.wear_gradient(k);
      wear_row_.head(moving - nu_).noalias() = sensitivity_.leftCols(moving - nu_).transpose() * gradient.head(nx_);
      wear_row_.segment(moving - nu_, nu_) = gradient.tail(nu_);
      const double weight = wear_curvature_weight(lambda, linearised.wear(k));
      hessian.topLeftCorner(moving, moving).selfadjointView<Eigen::Lower>().rankUpdate(wear_row_.head(moving), weight);
    }
    if (stage_curvature != nullptr) add_stage_curvature(k, stage_curvature->block(k), hessian);
    // The tracking residuals at x_{k+1} and the state effort's, stacked: dr/dU = dr/dx dx_{k+1}/dU.
    problem.tracking_residuals(k, states.col(k + 1), &residuals, &tracking_jacobian);
    residual_jacobian_.topLeftCorner(OcpProblem::kTrackingResiduals, moving).noalias() =
        tracking_jacobian * next_sensitivity_.topLeftCorner(OcpProblem::kTrackedStates, moving);
    for (Eigen::Index j = 0; j < effort_rows; ++j) {
      residual_jacobian_.row(OcpProblem::kTrackingResiduals + j).head(moving) =
          problem.state_effort_root()[j] * next_sensitivity_.row(problem.state_effort_index()[j]).head(moving);
    }
    hessian.topLeftCorner(moving, moving)
        .selfadjointView<Eigen::Lower>()
        .rankUpdate(residual_jacobian_.leftCols(moving).transpose());
    std::swap(sensitivity_, next_sensitivity_);
  }
  // Effort R on each u_k; rate S on u_k - u_{k-1} (u_{-1} fixed): S on both diagonals, -S between.
  for (int k = 0; k < horizon_; ++k) {
    for (int i = 0; i < nu_; ++i) {
      const int j = k * nu_ + i;
      const double effort = problem.effort_root()[i] * problem.effort_root()[i];
      const double rate = problem.rate_root()[i] * problem.rate_root()[i];
      hessian(j, j) += effort + rate;
      if (k > 0) {
        hessian(j - nu_, j - nu_) += rate;
        hessian(j, j - nu_) -= rate;
      }
    }
  }
  for (int j = 1; j < n_; ++j) {
    for (int i = 0; i < j; ++i) hessian(i, j) = hessian(j, i);
  }
  return hessian.allFinite();
}

void CondensedGaussNewton::add_stage_curvature(int k, const Eigen::MatrixXd& curvature,
                                               Eigen::Ref<Eigen::MatrixXd> hessian) noexcept {
  // M_k = [dx_k/dU; du_k/dU] over the first (k + 1) nu columns: the sensitivity, and u_k's identity.
  const Eigen::Index moving = static_cast<Eigen::Index>(k + 1) * nu_;
  if (curvature.isZero(0.0)) return;
  stage_map_.leftCols(moving).setZero();
  stage_map_.topLeftCorner(nx_, moving) = sensitivity_.leftCols(moving);
  stage_map_.block(nx_, moving - nu_, nu_, nu_).setIdentity();
  curved_map_.leftCols(moving).noalias() = curvature * stage_map_.leftCols(moving);
  hessian.topLeftCorner(moving, moving).noalias() +=
      stage_map_.leftCols(moving).transpose() * curved_map_.leftCols(moving);
}

}  // namespace swerve
