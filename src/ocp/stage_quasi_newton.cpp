#include "swerve/ocp/stage_quasi_newton.hpp"

#include "swerve/ocp/condensed_gauss_newton.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <utility>

namespace swerve {
namespace {

// A pair shorter than this (squared, in z's units) carries no curvature worth its rounding.
constexpr double kShortestPair = 1e-20;
// The first pair's curvature y^T y / s^T y, times this, is a new block's identity.
constexpr double kInitialShare = 1e-6;
// Powell's damping: the updated curvature along s keeps at least this share of the old one.
constexpr double kPowell = 0.2;

}  // namespace

StageQuasiNewton::StageQuasiNewton(const OcpProblem& shape)
    : horizon_(shape.horizon()), nx_(shape.state_size()), nu_(shape.input_size()), nz_(nx_ + nu_) {
  const auto n = static_cast<std::size_t>(horizon_);
  points_ = last_points_ = incoming_ = Eigen::MatrixXd::Zero(nz_, horizon_);
  a_.assign(n, Eigen::MatrixXd::Zero(nx_, nx_));
  last_a_ = a_;
  b_.assign(n, Eigen::MatrixXd::Zero(nx_, nu_));
  last_b_ = b_;
  curvature_.assign(n, Eigen::MatrixXd::Zero(nz_, nz_));
  last_curvature_ = curvature_;
  wear_.assign(n, Eigen::VectorXd::Zero(nz_));
  last_wear_ = wear_;
  remembered_.assign(n, 0);
  last_remembered_ = remembered_;
  gradient_ = last_gradient_ = s_ = y_ = bs_ = r_ = Eigen::VectorXd::Zero(nz_);
}

void StageQuasiNewton::reset() noexcept {
  for (std::size_t k = 0; k < curvature_.size(); ++k) {
    curvature_[k].setZero();
    last_curvature_[k].setZero();
    remembered_[k] = last_remembered_[k] = 0;
  }
  new_solve_ = true;
}

void StageQuasiNewton::damped_bfgs(Eigen::MatrixXd* b, const Eigen::VectorXd& s, const Eigen::VectorXd& y,
                                   Eigen::VectorXd* bs, Eigen::VectorXd* r) noexcept {
  const double ss = s.squaredNorm();
  const double sy = s.dot(y);
  if (!(ss > kShortestPair) || !s.allFinite() || !y.allFinite()) return;
  if (b->isZero(0.0)) {
    // BFGS keeps a singular matrix's rank (each update removes a direction as it adds one), so a
    // block that knows nothing starts as a faint multiple of the identity at the pair's scale
    // (Nocedal & Wright, 6.20, scaled down so that unexplored directions stay all but free).
    if (!(sy > 0.0)) return;
    b->setIdentity();
    *b *= kInitialShare * y.squaredNorm() / sy;
  }
  bs->noalias() = *b * s;
  const double sbs = s.dot(*bs);
  if (!(sbs > 0.0)) return;
  // Powell: where s^T y < 0.2 s^T B s (negative or small curvature), y is moved towards B s.
  const double theta = sy >= kPowell * sbs ? 1.0 : (1.0 - kPowell) * sbs / (sbs - sy);
  *r = theta * y + (1.0 - theta) * *bs;
  const double sr = s.dot(*r);
  b->noalias() -= (*bs / sbs) * bs->transpose();
  b->noalias() += (*r / sr) * r->transpose();
}

void StageQuasiNewton::lagrangian_gradient(double lambda, const Eigen::MatrixXd& a, const Eigen::MatrixXd& b,
                                           const Eigen::VectorXd& wear_gradient,
                                           const Eigen::Ref<const Eigen::VectorXd>& mu,
                                           Eigen::VectorXd* gradient) const noexcept {
  gradient->head(nx_).noalias() = a.transpose() * mu;
  gradient->tail(nu_).noalias() = b.transpose() * mu;
  *gradient += lambda * wear_gradient;
}

bool StageQuasiNewton::shifted(const Eigen::MatrixXd& points) const noexcept {
  double same = 0.0, moved = 0.0;
  for (int k = 0; k < horizon_; ++k) {
    same += (points.col(k) - last_points_.col(k)).squaredNorm();
    moved += (points.col(k) - last_points_.col(std::min(k + 1, horizon_ - 1))).squaredNorm();
  }
  return moved < same;
}

void StageQuasiNewton::update(const OcpProblem& problem, const OcpDerivatives& linearised,
                              const Eigen::Ref<const Eigen::MatrixXd>& states,
                              const Eigen::Ref<const Eigen::MatrixXd>& inputs, bool wear_curvature) noexcept {
  if (states.rows() != nx_ || states.cols() != horizon_ + 1 || inputs.rows() != nu_ || inputs.cols() != horizon_) return;
  incoming_.topRows(nx_) = states.leftCols(horizon_);
  incoming_.bottomRows(nu_) = inputs;
  update_at(problem, linearised, incoming_, linearised.costates(), wear_curvature);
}

void StageQuasiNewton::update_at(const OcpProblem& problem, const OcpDerivatives& linearised,
                                 const Eigen::Ref<const Eigen::MatrixXd>& points,
                                 const Eigen::Ref<const Eigen::MatrixXd>& costates, bool wear_curvature) noexcept {
  if (problem.state_size() != nx_ || problem.input_size() != nu_ || problem.horizon() != horizon_ ||
      points.rows() != nz_ || points.cols() != horizon_ || costates.rows() != nx_ || costates.cols() != horizon_) {
    return;
  }
  // This linearisation becomes the remembered one: the buffers swap, and the last one is read from
  // the last_* side.
  std::swap(points_, last_points_);
  std::swap(a_, last_a_);
  std::swap(b_, last_b_);
  std::swap(wear_, last_wear_);
  std::swap(curvature_, last_curvature_);
  std::swap(remembered_, last_remembered_);
  points_ = points;
  const int offset = new_solve_ && shifted(points_) ? 1 : 0;
  new_solve_ = false;
  const double lambda = problem.weights().wear;
  for (int k = 0; k < horizon_; ++k) {
    const auto stage = static_cast<std::size_t>(k);
    const auto last = static_cast<std::size_t>(std::min(k + offset, horizon_ - 1));
    a_[stage] = linearised.a(k);
    b_[stage] = linearised.b(k);
    wear_[stage] = linearised.wear_gradient(k);
    curvature_[stage] = last_curvature_[last];
    remembered_[stage] = 1;
    if (!last_remembered_[last]) continue;
    // The pair at this update's multipliers: both gradients of the same stage function.
    const Eigen::Ref<const Eigen::VectorXd> mu = costates.col(k);
    lagrangian_gradient(lambda, a_[stage], b_[stage], wear_[stage], mu, &gradient_);
    lagrangian_gradient(lambda, last_a_[last], last_b_[last], last_wear_[last], mu, &last_gradient_);
    s_ = points_.col(k) - last_points_.col(static_cast<Eigen::Index>(last));
    y_ = gradient_ - last_gradient_;
    if (wear_curvature && lambda > 0.0) {
      const double weight = CondensedGaussNewton::wear_curvature_weight(lambda, linearised.wear(k));
      y_ -= weight * wear_[stage].dot(s_) * wear_[stage];
    }
    damped_bfgs(&curvature_[stage], s_, y_, &bs_, &r_);
  }
}

}  // namespace swerve
