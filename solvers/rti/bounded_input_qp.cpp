#include "swerve/solvers/bounded_input_qp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// The fraction of the way to the boundary a step goes (Nocedal & Wright, 16.6: 0.995 works well).
constexpr double kToBoundary = 0.995;

double entry_or(const Eigen::VectorXd& values, int i, double fallback) noexcept {
  return values.size() == 0 ? fallback : values[i];
}

}  // namespace

BoundedInputQp::BoundedInputQp(int input_size, int horizon) : nu_(input_size), horizon_(horizon) {
  if (input_size < 1) throw ConfigError("BoundedInputQp: input_size = " + std::to_string(input_size) + ": must be >= 1");
  if (horizon < 1 || horizon > kMaxHorizon) {
    throw ConfigError("BoundedInputQp: horizon = " + std::to_string(horizon) + ": must be in [1, " +
                      std::to_string(kMaxHorizon) + "]");
  }
  n_ = nu_ * horizon_;
  const int capacity = 4 * n_;
  rows_.resize(static_cast<std::size_t>(capacity));
  slack_ = multiplier_ = row_residual_ = complementarity_ = scaled_ = ds_ = dl_ = Eigen::VectorXd::Zero(capacity);
  dual_residual_ = dz_ = rhs_ = Eigen::VectorXd::Zero(n_);
  normal_ = Eigen::MatrixXd::Zero(n_, n_);
  factor_ = Eigen::LLT<Eigen::MatrixXd>(n_);
}

void BoundedInputQp::add_side(int plus, int minus, double lower, double upper) noexcept {
  if (std::isfinite(lower)) rows_[static_cast<std::size_t>(m_++)] = Inequality{plus, minus, 1.0, lower};
  if (std::isfinite(upper)) rows_[static_cast<std::size_t>(m_++)] = Inequality{plus, minus, -1.0, -upper};
}

void BoundedInputQp::build_inequalities(const InputBounds& bounds,
                                        const Eigen::Ref<const Eigen::VectorXd>& previous_input) noexcept {
  m_ = 0;
  const double infinity = std::numeric_limits<double>::infinity();
  for (int k = 0; k < horizon_; ++k) {
    for (int i = 0; i < nu_; ++i) {
      const int j = k * nu_ + i;
      add_side(j, -1, entry_or(bounds.lower, i, -infinity), entry_or(bounds.upper, i, infinity));
      const double step = entry_or(bounds.max_step, i, infinity);
      if (!std::isfinite(step)) continue;
      if (k == 0) {
        add_side(j, -1, previous_input[i] - step, previous_input[i] + step);
      } else {
        add_side(j, j - nu_, -step, step);
      }
    }
  }
}

double BoundedInputQp::row_value(int i, const Eigen::Ref<const Eigen::VectorXd>& z) const noexcept {
  const Inequality& row = rows_[static_cast<std::size_t>(i)];
  return row.sign * (z[row.plus] - (row.minus >= 0 ? z[row.minus] : 0.0));
}

void BoundedInputQp::add_transposed(const Eigen::VectorXd& values, Eigen::VectorXd* out) const noexcept {
  for (int i = 0; i < m_; ++i) {
    const Inequality& row = rows_[static_cast<std::size_t>(i)];
    (*out)[row.plus] += row.sign * values[i];
    if (row.minus >= 0) (*out)[row.minus] -= row.sign * values[i];
  }
}

// (H + C^T D C) dz = -r_d - C^T ((r_c + lambda r_p) / s), then ds = C dz + r_p and
// dlambda = -(r_c + lambda ds) / s: the Newton step on H z + q - C^T lambda = 0, C z - s - b = 0,
// s lambda = sigma mu, with D = lambda / s (the factorisation of normal_ is current).
void BoundedInputQp::newton_direction(const Eigen::VectorXd& complementarity) noexcept {
  for (int i = 0; i < m_; ++i) {
    scaled_[i] = (complementarity[i] + multiplier_[i] * row_residual_[i]) / slack_[i];
  }
  rhs_ = -dual_residual_;
  scaled_.head(m_) = -scaled_.head(m_);
  add_transposed(scaled_, &rhs_);
  factor_.solveInPlace(rhs_);
  dz_ = rhs_;
  for (int i = 0; i < m_; ++i) {
    const Inequality& row = rows_[static_cast<std::size_t>(i)];
    const double c_dz = row.sign * (dz_[row.plus] - (row.minus >= 0 ? dz_[row.minus] : 0.0));
    ds_[i] = c_dz + row_residual_[i];
    dl_[i] = -(complementarity[i] + multiplier_[i] * ds_[i]) / slack_[i];
  }
}

double BoundedInputQp::step_to_boundary() const noexcept {
  double step = std::numeric_limits<double>::infinity();
  for (int i = 0; i < m_; ++i) {
    if (ds_[i] < 0.0) step = std::min(step, -slack_[i] / ds_[i]);
    if (dl_[i] < 0.0) step = std::min(step, -multiplier_[i] / dl_[i]);
  }
  return step;
}

BoundedInputQp::Result BoundedInputQp::solve(const Eigen::Ref<const Eigen::MatrixXd>& hessian,
                                             const Eigen::Ref<const Eigen::VectorXd>& linear,
                                             const InputBounds& bounds,
                                             const Eigen::Ref<const Eigen::VectorXd>& previous_input,
                                             const Settings& settings, Eigen::Ref<Eigen::VectorXd> z) noexcept {
  Result result;
  const auto size_ok = [&](const Eigen::VectorXd& v) { return v.size() == 0 || v.size() == nu_; };
  if (hessian.rows() != n_ || hessian.cols() != n_ || linear.size() != n_ || z.size() != n_ ||
      previous_input.size() != nu_ || !size_ok(bounds.lower) || !size_ok(bounds.upper) || !size_ok(bounds.max_step)) {
    result.reason = "wrong sizes";
    return result;
  }
  if (!hessian.allFinite() || !linear.allFinite() || !z.allFinite() || !previous_input.allFinite()) {
    result.reason = "non-finite Hessian, linear term, start or previous input";
    return result;
  }
  build_inequalities(bounds, previous_input);
  // The start: z as given, every slack at least 1 (the scale of an input in SI units), every
  // multiplier 1; the infeasible-start method needs no feasible point.
  for (int i = 0; i < m_; ++i) {
    slack_[i] = std::max(row_value(i, z) - rows_[static_cast<std::size_t>(i)].bound, 1.0);
    multiplier_[i] = 1.0;
  }
  const double linear_scale = 1.0 + linear.lpNorm<Eigen::Infinity>();
  double bound_scale = 1.0;
  for (int i = 0; i < m_; ++i) bound_scale = std::max(bound_scale, 1.0 + std::abs(rows_[static_cast<std::size_t>(i)].bound));
  for (int iteration = 0; iteration <= settings.max_iterations; ++iteration) {
    // Residuals: r_d = H z + q - C^T lambda, r_p = C z - s - b, mu = s^T lambda / m.
    dual_residual_.noalias() = hessian * z;
    dual_residual_ += linear;
    scaled_.head(m_) = -multiplier_.head(m_);
    add_transposed(scaled_, &dual_residual_);
    double primal = 0.0;
    for (int i = 0; i < m_; ++i) {
      row_residual_[i] = row_value(i, z) - slack_[i] - rows_[static_cast<std::size_t>(i)].bound;
      primal = std::max(primal, std::abs(row_residual_[i]));
    }
    const double mu = m_ > 0 ? slack_.head(m_).dot(multiplier_.head(m_)) / m_ : 0.0;
    result.iterations = iteration;
    if (dual_residual_.lpNorm<Eigen::Infinity>() <= settings.tolerance * linear_scale &&
        primal <= settings.tolerance * bound_scale && mu <= settings.tolerance) {
      result.converged = true;
      result.reason = "converged";
      break;
    }
    if (iteration == settings.max_iterations) {
      result.reason = "stopped at max_iterations";
      break;
    }
    // The normal matrix H + C^T diag(lambda / s) C: each row adds its weight to one diagonal entry,
    // or to a 2 x 2 block of two consecutive steps' inputs.
    normal_ = hessian;
    for (int i = 0; i < m_; ++i) {
      const Inequality& row = rows_[static_cast<std::size_t>(i)];
      const double weight = multiplier_[i] / slack_[i];
      normal_(row.plus, row.plus) += weight;
      if (row.minus >= 0) {
        normal_(row.minus, row.minus) += weight;
        normal_(row.plus, row.minus) -= weight;
        normal_(row.minus, row.plus) -= weight;
      }
    }
    factor_.compute(normal_);
    if (factor_.info() != Eigen::Success) {
      result.reason = "the normal matrix is not positive definite (is the Hessian?)";
      result.not_positive_definite = true;
      break;
    }
    // Predictor (affine scaling): complementarity s lambda driven to 0.
    for (int i = 0; i < m_; ++i) complementarity_[i] = slack_[i] * multiplier_[i];
    newton_direction(complementarity_);
    double step = std::min(1.0, step_to_boundary());
    double mu_affine = 0.0;
    for (int i = 0; i < m_; ++i) mu_affine += (slack_[i] + step * ds_[i]) * (multiplier_[i] + step * dl_[i]);
    mu_affine = m_ > 0 ? mu_affine / m_ : 0.0;
    const double centering = mu > 0.0 ? std::pow(mu_affine / mu, 3) : 0.0;
    // Corrector: the predictor's second-order term and the centring sigma mu.
    for (int i = 0; i < m_; ++i) complementarity_[i] += ds_[i] * dl_[i] - centering * mu;
    newton_direction(complementarity_);
    step = std::min(1.0, kToBoundary * step_to_boundary());
    z += step * dz_;
    slack_.head(m_) += step * ds_.head(m_);
    multiplier_.head(m_) += step * dl_.head(m_);
    if (!z.allFinite()) {
      result.reason = "the iterate became non-finite";
      break;
    }
  }
  dual_residual_.noalias() = hessian * z;
  result.objective = 0.5 * z.dot(dual_residual_) + linear.dot(z);
  return result;
}

}  // namespace swerve
