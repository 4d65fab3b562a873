#include "projected_lbfgs.hpp"

namespace swerve {

LbfgsMemory::LbfgsMemory(Eigen::Index max_size, int pairs)
    : pairs_(pairs),
      s_(Eigen::MatrixXd::Zero(max_size, pairs)),
      y_(Eigen::MatrixXd::Zero(max_size, pairs)),
      rho_(Eigen::VectorXd::Zero(pairs)),
      alpha_(Eigen::VectorXd::Zero(pairs)) {}

void LbfgsMemory::clear() noexcept {
  stored_ = 0;
  newest_ = -1;
}

bool LbfgsMemory::apply_inverse_hessian(const Eigen::Ref<const Eigen::VectorXd>& g,
                                        Eigen::Ref<Eigen::VectorXd> d) noexcept {
  const Eigen::Index n = g.size();
  for (int back = 0; back < stored_; ++back) {
    const int j = (newest_ - back + pairs_) % pairs_;
    alpha_[j] = rho_[j] * s_.col(j).head(n).dot(d);
    d -= alpha_[j] * y_.col(j).head(n);
  }
  if (stored_ > 0) d *= s_.col(newest_).head(n).dot(y_.col(newest_).head(n)) / y_.col(newest_).head(n).squaredNorm();
  for (int back = stored_ - 1; back >= 0; --back) {
    const int j = (newest_ - back + pairs_) % pairs_;
    const double beta = rho_[j] * y_.col(j).head(n).dot(d);
    d += (alpha_[j] - beta) * s_.col(j).head(n);
  }
  if (g.dot(d) < 0.0) return true;
  clear();  // not a descent direction: forget the memory
  return false;
}

void LbfgsMemory::remember(const Eigen::Ref<const Eigen::VectorXd>& x_new, const Eigen::Ref<const Eigen::VectorXd>& x_old,
                           const Eigen::Ref<const Eigen::VectorXd>& g_new,
                           const Eigen::Ref<const Eigen::VectorXd>& g_old) noexcept {
  // The differences go straight into the next slot: an expression bound to a Ref<const VectorXd>
  // is evaluated into a heap temporary, and the polish then allocated on every step it took.
  const int slot = (newest_ + 1) % pairs_;
  const Eigen::Index n = x_new.size();
  auto s = s_.col(slot).head(n);
  auto y = y_.col(slot).head(n);
  s = x_new - x_old;
  y = g_new - g_old;
  // Otherwise the slot is scratch and the memory is unchanged.
  const double curvature = s.dot(y);
  if (!(curvature > 1e-12 * s.norm() * y.norm())) return;
  newest_ = slot;
  rho_[slot] = 1.0 / curvature;
  stored_ = std::min(stored_ + 1, pairs_);
}

}  // namespace swerve
