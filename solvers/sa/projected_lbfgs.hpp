// The pieces of the annealer's projected L-BFGS polish (Nocedal & Wright, Numerical Optimization,
// 2nd ed.): the limited memory of curvature pairs with its two-loop recursion (Alg. 7.4), and the
// Armijo backtracking search on the true cost (eq. 3.6a). The exact polish runs them over the plan's
// inputs, the knot polish over its knot offsets. Allocation-free after construction.
#pragma once

#include <Eigen/Core>

#include <algorithm>

#include "swerve/ocp/deadline.hpp"

namespace swerve {

class LbfgsMemory {
 public:
  // Room for `pairs` curvature pairs of vectors of up to `max_size` entries.
  LbfgsMemory(Eigen::Index max_size, int pairs);

  // Forgets every pair (a new polish starts from steepest descent).
  void clear() noexcept;
  bool empty() const noexcept { return stored_ == 0; }

  // d = -H g by the two-loop recursion, H scaled by s'y / y'y of the newest pair; `d` holds -g
  // already, any first-step scaling applied. With no pair stored, d is left as given. True when d
  // is a descent direction (g'd < 0); otherwise the memory is cleared and false returned.
  bool apply_inverse_hessian(const Eigen::Ref<const Eigen::VectorXd>& g, Eigen::Ref<Eigen::VectorXd> d) noexcept;

  // Stores the pair s = x_new - x_old, y = g_new - g_old when its curvature s'y is positive (else H
  // would not stay positive definite), replacing the oldest when full.
  void remember(const Eigen::Ref<const Eigen::VectorXd>& x_new, const Eigen::Ref<const Eigen::VectorXd>& x_old,
                const Eigen::Ref<const Eigen::VectorXd>& g_new, const Eigen::Ref<const Eigen::VectorXd>& g_old) noexcept;

 private:
  int pairs_;
  int stored_ = 0, newest_ = -1;
  Eigen::MatrixXd s_, y_;      // max_size x pairs
  Eigen::VectorXd rho_, alpha_;  // pairs
};

// Backtracking from the full step (x0.3 a trial, at most kLineSearchTrials) until the true cost
// falls by the Armijo condition f(step) <= f + 1e-4 g'(x(step) - x). `trial(step, &cost, &decrease)`
// makes and rolls out the candidate at `step`, writing its cost and g'(x(step) - x); false when
// there is no candidate (the search ends). Each trial's time raises *rollout, and no further trial
// starts when one more would end past `stop`. True with *accepted_cost when a candidate is accepted
// (it is the last one the trial made).
inline constexpr int kLineSearchTrials = 8;
template <typename Trial>
bool armijo_backtracking(double cost, const Deadline& deadline, TimePoint stop, Duration* rollout, long* rollouts,
                         Trial&& trial, double* accepted_cost) noexcept {
  double step = 1.0;
  for (int t = 0; t < kLineSearchTrials; ++t, step *= 0.3) {
    const TimePoint start = deadline.now();
    double candidate_cost = 0.0, decrease = 0.0;
    if (!trial(step, &candidate_cost, &decrease)) return false;
    *rollout = std::max(*rollout, deadline.now() - start);
    ++*rollouts;
    if (candidate_cost <= cost + 1e-4 * decrease && candidate_cost < cost) {
      *accepted_cost = candidate_cost;
      return true;
    }
    if (deadline.now() + *rollout >= stop) return false;
  }
  return false;
}

}  // namespace swerve
