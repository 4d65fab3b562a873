#include "swerve/ocp/ocp_derivatives.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// Whether a stage begun at `stage_start` and costing what this one did would, after it, end past
// `stop` (null: never): a gradient gives up between stages rather than return late.
bool next_stage_would_end_late(const Deadline* stop, TimePoint stage_start) noexcept {
  if (stop == nullptr) return false;
  const TimePoint now = stop->now();
  return now + (now - stage_start) >= stop->at();
}

}  // namespace

OcpDerivatives::OcpDerivatives(const OcpProblem& shape)
    : horizon_(shape.horizon()),
      nx_(shape.state_size()),
      nu_(shape.input_size()),
      workspace_(shape.model(), 1) {
  if (!shape.model().has_jacobians()) {
    throw ConfigError("OcpDerivatives: the problem's prediction model has no exact Jacobians (has_jacobians() is "
                      "false); gradient backends need them");
  }
  const auto n = static_cast<std::size_t>(horizon_);
  a_.assign(n, Eigen::MatrixXd::Zero(nx_, nx_));
  b_.assign(n, Eigen::MatrixXd::Zero(nx_, nu_));
  wear_gradient_.assign(n, Eigen::VectorXd::Zero(nx_ + nu_));
  wear_ = Eigen::VectorXd::Zero(horizon_);
  costate_ = Eigen::VectorXd::Zero(nx_);
  costates_ = Eigen::MatrixXd::Zero(nx_, horizon_);
  d_x_next_ = Eigen::VectorXd::Zero(nx_);
  d_u_ = Eigen::VectorXd::Zero(nu_);
  d_u_before_ = Eigen::VectorXd::Zero(nu_);
  scratch_ = Eigen::VectorXd::Zero(nx_);
}

bool OcpDerivatives::linearize_stage(const OcpProblem& problem, int k, const Eigen::Ref<const Eigen::VectorXd>& x_k,
                                     const Eigen::Ref<const Eigen::VectorXd>& u_k,
                                     Eigen::Ref<Eigen::VectorXd> x_next) noexcept {
  if (!workspace_.bind(problem.model())) return false;
  return linearize_stage_on(workspace_.data(), problem, k, x_k, u_k, x_next);
}

bool OcpDerivatives::linearize_stage_on(PredictionData& data, const OcpProblem& problem, int k,
                                        const Eigen::Ref<const Eigen::VectorXd>& x_k,
                                        const Eigen::Ref<const Eigen::VectorXd>& u_k,
                                        Eigen::Ref<Eigen::VectorXd> x_next) noexcept {
  if (k < 0 || k >= horizon_) return false;
  const auto s = static_cast<std::size_t>(k);
  double wear = 0.0;
  const bool ok =
      problem.model().step_jacobians(data, x_k, u_k, problem.dt(), x_next, a_[s], b_[s], &wear, wear_gradient_[s]);
  wear_[k] = wear;
  return ok && std::isfinite(wear);
}

double OcpDerivatives::cost_and_gradient(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                         Eigen::Ref<Eigen::MatrixXd> states, Eigen::Ref<Eigen::MatrixXd> gradient,
                                         const Deadline* stop) noexcept {
  gradient.setZero();
  states.col(0) = problem.initial_state();
  completed_stages_ = 0;
  for (int k = 0; k < horizon_; ++k) {
    const TimePoint stage_start = stop != nullptr ? stop->now() : TimePoint{};
    if (!linearize_stage(problem, k, states.col(k), inputs.col(k), states.col(k + 1))) {
      return std::numeric_limits<double>::infinity();
    }
    completed_stages_ = k + 1;
    if (k + 1 < horizon_ && next_stage_would_end_late(stop, stage_start)) return std::numeric_limits<double>::quiet_NaN();
  }
  return gradient_of_stages(problem, inputs, states, gradient);
}

int OcpDerivatives::linearize_stages(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                     const Eigen::Ref<const Eigen::MatrixXd>& states, int first, int last,
                                     PredictionData& data, Eigen::Ref<Eigen::VectorXd> x_next,
                                     const Deadline* stop) noexcept {
  first = std::max(first, 0);
  last = std::min(last, horizon_);
  for (int k = first; k < last; ++k) {
    const TimePoint stage_start = stop != nullptr ? stop->now() : TimePoint{};
    if (!linearize_stage_on(data, problem, k, states.col(k), inputs.col(k), x_next)) return -1;
    if (k + 1 < last && next_stage_would_end_late(stop, stage_start)) return k + 1 - first;
  }
  return last - first;
}

double OcpDerivatives::gradient_of_stages(const OcpProblem& problem, const Eigen::Ref<const Eigen::MatrixXd>& inputs,
                                          const Eigen::Ref<const Eigen::MatrixXd>& states,
                                          Eigen::Ref<Eigen::MatrixXd> gradient) noexcept {
  gradient.setZero();
  const double lambda = problem.weights().wear;
  double cost = 0.0;
  // Backward: costate_ = dJ/dx_{k+1} of the stages after k, then of stage k's own tracking term.
  costate_.setZero();
  for (int k = horizon_ - 1; k >= 0; --k) {
    const auto s = static_cast<std::size_t>(k);
    const Eigen::Ref<const Eigen::VectorXd> u_before =
        k == 0 ? Eigen::Ref<const Eigen::VectorXd>(problem.previous_input())
               : Eigen::Ref<const Eigen::VectorXd>(inputs.col(k - 1));
    cost += problem.stage_cost_without_wear(k, states.col(k + 1), inputs.col(k), u_before, d_x_next_, d_u_, d_u_before_) +
            lambda * wear_[k];
    costate_ += d_x_next_;
    costates_.col(k) = costate_;
    gradient.col(k).noalias() += b_[s].transpose() * costate_;
    gradient.col(k) += d_u_ + lambda * wear_gradient_[s].tail(nu_);
    if (k > 0) gradient.col(k - 1) += d_u_before_;
    scratch_.noalias() = a_[s].transpose() * costate_;
    costate_ = scratch_ + lambda * wear_gradient_[s].head(nx_);
  }
  return cost;
}

void OcpDerivatives::propagate_sensitivity(int k, const Eigen::Ref<const Eigen::MatrixXd>& previous,
                                           Eigen::Ref<Eigen::MatrixXd> sensitivity) const noexcept {
  // previous = dx_k/du (nx x nu N); sensitivity = dx_{k+1}/du.
  const auto s = static_cast<std::size_t>(k);
  sensitivity.leftCols(static_cast<Eigen::Index>(k) * nu_).noalias() =
      a_[s] * previous.leftCols(static_cast<Eigen::Index>(k) * nu_);
  sensitivity.middleCols(static_cast<Eigen::Index>(k) * nu_, nu_) = b_[s];
  sensitivity.rightCols(static_cast<Eigen::Index>(horizon_ - k - 1) * nu_).setZero();
}

}  // namespace swerve
