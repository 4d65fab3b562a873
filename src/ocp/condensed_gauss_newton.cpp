#include "swerve/ocp/condensed_gauss_newton.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <utility>

namespace swerve {

CondensedGaussNewton::CondensedGaussNewton(const OcpProblem& shape)
    : horizon_(shape.horizon()), nx_(shape.state_size()), nu_(shape.input_size()), n_(nu_ * horizon_) {
  sensitivity_ = next_sensitivity_ = Eigen::MatrixXd::Zero(nx_, n_);
  const auto rows = static_cast<Eigen::Index>(OcpProblem::kTrackingResiduals) + shape.state_effort_index().size();
  residual_jacobian_ = Eigen::MatrixXd::Zero(rows, n_);
  wear_row_ = Eigen::VectorXd::Zero(n_);
  stage_map_ = curved_map_ = Eigen::MatrixXd::Zero(nx_ + nu_, n_);
  start_direction_ = Eigen::MatrixXd::Zero(nx_, horizon_ + 1);
  stage_terms_ = Eigen::MatrixXd::Zero(nx_ + nu_, horizon_);
  costate_direction_ = costate_scratch_ = Eigen::VectorXd::Zero(nx_);
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

bool CondensedGaussNewton::start_product(const OcpProblem& problem, const OcpDerivatives& linearised,
                                         const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                         const Eigen::Ref<const Eigen::MatrixXd>& states, bool wear_curvature,
                                         const Eigen::Ref<const Eigen::VectorXd>& dx0,
                                         const Eigen::Ref<const Eigen::VectorXd>& du_previous,
                                         Eigen::Ref<Eigen::VectorXd> product, const StageQuasiNewton* stage_curvature,
                                         double* cost_change) noexcept {
  if (problem.horizon() != horizon_ || problem.state_size() != nx_ || problem.input_size() != nu_ ||
      linearised.horizon() != horizon_ || inputs.rows() != nu_ || inputs.cols() != horizon_ || states.rows() != nx_ ||
      states.cols() != horizon_ + 1 ||
      dx0.size() != nx_ || du_previous.size() != nu_ || product.size() != n_ ||
      (stage_curvature != nullptr && stage_curvature->stage_size() != nx_ + nu_)) {
    return false;
  }
  // Forward: the states' change dx_k = A_{k-1} ... A_0 dx0 (the inputs held).
  start_direction_.col(0) = dx0;
  for (int k = 0; k < horizon_; ++k) start_direction_.col(k + 1).noalias() = linearised.a(k) * start_direction_.col(k);
  // Each stage's curvature over (x_k, u_k) times (dx_k, 0): the wear's Gauss-Newton term and the
  // learnt block, as hessian() adds them.
  const double lambda = problem.weights().wear;
  for (int k = 0; k < horizon_; ++k) {
    auto term = stage_terms_.col(k);
    term.setZero();
    if (wear_curvature && lambda > 0.0) {
      const Eigen::VectorXd& gradient = linearised.wear_gradient(k);
      const double along = gradient.head(nx_).dot(start_direction_.col(k));
      term.noalias() += wear_curvature_weight(lambda, linearised.wear(k)) * along * gradient;
    }
    if (stage_curvature != nullptr) term.noalias() += stage_curvature->block(k).leftCols(nx_) * start_direction_.col(k);
  }
  // Adjoint: costate_direction_ gathers d(dJ/dx_{k+1}) of the whole model, then moves to x_k.
  OcpProblem::TrackingResiduals residuals, residual_change;
  OcpProblem::TrackingJacobian tracking_jacobian;
  const Eigen::Index effort_rows = problem.state_effort_index().size();
  costate_direction_.setZero();
  double curvature = 0.0;  // (dx0, du)^T H (dx0, du): each term's square along the change
  for (int k = horizon_ - 1; k >= 0; --k) {
    problem.tracking_residuals(k, states.col(k + 1), &residuals, &tracking_jacobian);
    residual_change.noalias() = tracking_jacobian * start_direction_.col(k + 1).head<OcpProblem::kTrackedStates>();
    costate_direction_.head<OcpProblem::kTrackedStates>().noalias() += tracking_jacobian.transpose() * residual_change;
    curvature += residual_change.squaredNorm() + stage_terms_.col(k).head(nx_).dot(start_direction_.col(k));
    for (Eigen::Index j = 0; j < effort_rows; ++j) {
      const Eigen::Index i = problem.state_effort_index()[j];
      const double root = problem.state_effort_root()[j];
      costate_direction_[i] += root * root * start_direction_(i, k + 1);
      curvature += root * root * start_direction_(i, k + 1) * start_direction_(i, k + 1);
    }
    auto stage_product = product.segment(static_cast<Eigen::Index>(k) * nu_, nu_);
    stage_product = stage_terms_.col(k).tail(nu_);
    stage_product.noalias() += linearised.b(k).transpose() * costate_direction_;  // one statement allocates
    costate_scratch_.noalias() = linearised.a(k).transpose() * costate_direction_;
    costate_direction_ = costate_scratch_ + stage_terms_.col(k).head(nx_);
  }
  // The slope at the linearisation: through x_1 (the costate mu_0 after stage 0, and A_0 dx0 from
  // the forward pass) and stage 0's own wear.
  double slope = linearised.costates().col(0).dot(start_direction_.col(1));
  if (lambda > 0.0) slope += lambda * linearised.wear_gradient(0).head(nx_).dot(dx0);
  // The rate on u_0 - u_{-1}: its gradient over u_0 moves by -S du_{-1}, and the cost by
  // -S (u_0 - u_{-1}) du_{-1} at the linearisation's u_{-1}.
  for (int i = 0; i < nu_; ++i) {
    const double rate = problem.rate_root()[i] * problem.rate_root()[i];
    const double linearised_previous = problem.previous_input()[i] - du_previous[i];
    product[i] -= rate * du_previous[i];
    slope -= rate * (inputs(i, 0) - linearised_previous) * du_previous[i];
    curvature += rate * du_previous[i] * du_previous[i];
  }
  const double change = slope + 0.5 * curvature;
  if (cost_change != nullptr) *cost_change = change;
  return product.allFinite() && std::isfinite(change);
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
