// Prediction models whose optimal control problems have closed-form optima, for known-answer
// tests of the OCP builder and of every solver backend.
#pragma once

#include <Eigen/Dense>

#include "swerve/ocp/ocp_problem.hpp"

namespace swerve::testing {

// A planar double integrator on the tracked outputs: state (x, y, psi, vx, vy, r) with the
// velocities in the same (world) frame, input = accelerations; exact discretisation
// x+ = x + dt v + dt^2/2 u, v+ = v + dt u. Its "wear" over a step is wear_scale * dt * |u|^2,
// so the wear term is a known quadratic too.
class DoubleIntegratorModel final : public PredictionModel {
 public:
  explicit DoubleIntegratorModel(double wear_scale = 0.0) : wear_scale_(wear_scale) {}
  int state_size() const noexcept override { return 6; }
  int input_size() const noexcept override { return 3; }
  bool step(PredictionData&, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
            double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept override {
    x_next.head<3>() = x.head<3>() + dt * x.segment<3>(3) + 0.5 * dt * dt * u;
    x_next.segment<3>(3) = x.segment<3>(3) + dt * u;
    if (stage_wear != nullptr) *stage_wear = wear_scale_ * dt * u.squaredNorm();
    return x_next.allFinite();
  }
  bool has_jacobians() const noexcept override { return true; }
  bool step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                      const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                      Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                      Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept override {
    if (a.rows() != 6 || a.cols() != 6 || b.rows() != 6 || b.cols() != 3 || wear_gradient.size() != 9) return false;
    a = a_matrix(dt);
    b = b_matrix(dt);
    wear_gradient.head<6>().setZero();
    wear_gradient.tail<3>() = 2.0 * wear_scale_ * dt * u;
    return step(data, x, u, dt, x_next, stage_wear);
  }
  Eigen::Matrix<double, 6, 6> a_matrix(double dt) const {
    Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Identity();
    a.topRightCorner<3, 3>() = dt * Eigen::Matrix3d::Identity();
    return a;
  }
  Eigen::Matrix<double, 6, 3> b_matrix(double dt) const {
    Eigen::Matrix<double, 6, 3> b;
    b << 0.5 * dt * dt * Eigen::Matrix3d::Identity(), dt * Eigen::Matrix3d::Identity();
    return b;
  }
  double wear_scale() const { return wear_scale_; }

 private:
  double wear_scale_;
};

// A model without exact Jacobians (the state stands still): what the gradient backends must refuse.
class ModelWithoutJacobians final : public PredictionModel {
 public:
  int state_size() const noexcept override { return 6; }
  int input_size() const noexcept override { return 1; }
  bool step(PredictionData&, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>&,
            double, Eigen::Ref<Eigen::VectorXd> x_next, double*) const noexcept override {
    x_next = x;
    return true;
  }
};

// The known-answer tracking problem every backend is tested on: from rest at the origin, follow a
// line at (0.1, 0.05, 0.01) per step, with effort, rate and wear terms all active.
inline OcpProblem make_lq_problem(const PredictionModel& model, int horizon, InputBounds bounds = {}) {
  CostWeights w;
  w.pose = {10.0, 10.0, 5.0};
  w.terminal_scale = 10.0;
  w.effort = Eigen::Vector3d::Constant(0.1);
  w.rate = Eigen::Vector3d::Constant(0.5);
  w.wear = 1.0;
  OcpProblem problem(model, horizon, 0.1, w, bounds);
  for (int k = 1; k <= horizon; ++k) problem.set_reference(k, {0.1 * k, 0.05 * k, 0.01 * k}, Eigen::Vector3d::Zero());
  return problem;
}

// The unconstrained optimum of an OcpProblem over a DoubleIntegratorModel, from the normal
// equations of the stacked quadratic (heading errors must stay small: no wrapping).
inline Eigen::MatrixXd double_integrator_optimum(const OcpProblem& problem, const DoubleIntegratorModel& model) {
  const int n = problem.horizon();
  const double dt = problem.dt();
  const auto a = model.a_matrix(dt);
  const auto b = model.b_matrix(dt);
  const CostWeights& w = problem.weights();
  // Stacked predictions X = Phi U + x_free, X = [x_1; ...; x_N].
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(6 * n, 3 * n);
  Eigen::VectorXd x_free(6 * n);
  Eigen::Matrix<double, 6, 1> x = problem.initial_state();
  for (int k = 0; k < n; ++k) {
    x = a * x;
    x_free.segment<6>(6 * k) = x;
    for (int j = 0; j <= k; ++j) {
      Eigen::Matrix<double, 6, 6> ak = Eigen::Matrix<double, 6, 6>::Identity();
      for (int p = 0; p < k - j; ++p) ak = a * ak;
      phi.block<6, 3>(6 * k, 3 * j) = ak * b;
    }
  }
  Eigen::VectorXd weight(6 * n), target = Eigen::VectorXd::Zero(6 * n);
  for (int k = 0; k < n; ++k) {
    const double scale = k == n - 1 ? w.terminal_scale : 1.0;
    weight.segment<3>(6 * k) = scale * w.pose;
    weight.segment<3>(6 * k + 3) = w.twist;
    target.segment<3>(6 * k) = problem.reference_poses().col(k);
  }
  // Effort and wear are both quadratic in u; rate couples neighbours through D U - d.
  Eigen::VectorXd effort(3 * n), rate(3 * n);
  for (int k = 0; k < n; ++k) {
    effort.segment<3>(3 * k) = problem.weights().effort + Eigen::Vector3d::Constant(w.wear * model.wear_scale() * dt);
    rate.segment<3>(3 * k) = problem.weights().rate;
  }
  Eigen::MatrixXd d = Eigen::MatrixXd::Identity(3 * n, 3 * n);
  for (int k = 1; k < n; ++k) d.block<3, 3>(3 * k, 3 * (k - 1)) = -Eigen::Matrix3d::Identity();
  Eigen::VectorXd d0 = Eigen::VectorXd::Zero(3 * n);
  d0.head<3>() = problem.previous_input();
  const Eigen::MatrixXd hessian = phi.transpose() * weight.asDiagonal() * phi + Eigen::MatrixXd(effort.asDiagonal()) +
                                  d.transpose() * rate.asDiagonal() * d;
  const Eigen::VectorXd gradient =
      phi.transpose() * weight.asDiagonal() * (x_free - target) - d.transpose() * rate.asDiagonal() * d0;
  const Eigen::VectorXd u = hessian.ldlt().solve(-gradient);
  return Eigen::Map<const Eigen::MatrixXd>(u.data(), 3, n);
}

}  // namespace swerve::testing
