// The interior point of the SQP backends' QP against independent answers: the Newton point when no
// bound is active, and on small random problems the best of every active set (each bound inactive,
// at its lower side or at its upper side), solved as an equality-constrained QP by a dense KKT
// system.
#include "swerve/solvers/bounded_input_qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::MatrixXd random_positive_definite(int n, std::mt19937* random) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd m(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) m(i, j) = normal(*random);
  }
  return m * m.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
}

// One two-sided constraint l <= a^T z <= u of the problem, written out densely.
struct DenseConstraint {
  Eigen::VectorXd row;
  double lower, upper;
};

std::vector<DenseConstraint> dense_constraints(const InputBounds& bounds, const Eigen::VectorXd& previous, int nu,
                                               int horizon) {
  std::vector<DenseConstraint> constraints;
  const int n = nu * horizon;
  for (int k = 0; k < horizon; ++k) {
    for (int i = 0; i < nu; ++i) {
      Eigen::VectorXd box = Eigen::VectorXd::Zero(n);
      box[k * nu + i] = 1.0;
      constraints.push_back({box, bounds.lower[i], bounds.upper[i]});
      Eigen::VectorXd change = box;
      double offset = 0.0;
      if (k > 0) {
        change[(k - 1) * nu + i] = -1.0;
      } else {
        offset = previous[i];
      }
      constraints.push_back({change, offset - bounds.max_step[i], offset + bounds.max_step[i]});
    }
  }
  return constraints;
}

// The optimum by enumeration: every assignment of each constraint to inactive, lower or upper, its
// equality-constrained minimiser (KKT system, least squares where rows are dependent), kept when
// feasible; the cheapest feasible one is the convex QP's optimum.
Eigen::VectorXd enumerated_optimum(const Eigen::MatrixXd& h, const Eigen::VectorXd& q,
                                   const std::vector<DenseConstraint>& constraints, double* objective) {
  const int n = static_cast<int>(q.size());
  const int m = static_cast<int>(constraints.size());
  int assignments = 1;
  for (int i = 0; i < m; ++i) assignments *= 3;
  Eigen::VectorXd best;
  *objective = kInf;
  for (int code = 0; code < assignments; ++code) {
    std::vector<int> active;
    std::vector<double> values;
    int c = code;
    for (int i = 0; i < m; ++i, c /= 3) {
      if (c % 3 == 1) { active.push_back(i); values.push_back(constraints[static_cast<std::size_t>(i)].lower); }
      if (c % 3 == 2) { active.push_back(i); values.push_back(constraints[static_cast<std::size_t>(i)].upper); }
    }
    const int a = static_cast<int>(active.size());
    if (a > n) continue;
    Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + a, n + a);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + a);
    kkt.topLeftCorner(n, n) = h;
    rhs.head(n) = -q;
    for (int j = 0; j < a; ++j) {
      const Eigen::VectorXd& row = constraints[static_cast<std::size_t>(active[static_cast<std::size_t>(j)])].row;
      kkt.block(n + j, 0, 1, n) = row.transpose();
      kkt.block(0, n + j, n, 1) = row;
      rhs[n + j] = values[static_cast<std::size_t>(j)];
    }
    const Eigen::VectorXd solution = kkt.completeOrthogonalDecomposition().solve(rhs);
    const Eigen::VectorXd z = solution.head(n);
    bool feasible = (kkt * solution - rhs).norm() < 1e-9;
    for (const DenseConstraint& constraint : constraints) {
      const double value = constraint.row.dot(z);
      feasible = feasible && value >= constraint.lower - 1e-9 && value <= constraint.upper + 1e-9;
    }
    if (!feasible) continue;
    const double value = 0.5 * z.dot(h * z) + q.dot(z);
    if (value < *objective) {
      *objective = value;
      best = z;
    }
  }
  return best;
}

TEST(BoundedInputQp, WithoutBoundsReturnsTheNewtonPoint) {
  std::mt19937 random(3);
  const int nu = 3, horizon = 4, n = nu * horizon;
  const Eigen::MatrixXd h = random_positive_definite(n, &random);
  const Eigen::VectorXd q = Eigen::VectorXd::LinSpaced(n, -2.0, 3.0);
  BoundedInputQp qp(nu, horizon);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n);
  const BoundedInputQp::Result result = qp.solve(h, q, InputBounds{}, Eigen::VectorXd::Zero(nu), {}, z);
  ASSERT_TRUE(result.converged) << result.reason;
  const Eigen::VectorXd newton = -h.llt().solve(q);
  EXPECT_LE((z - newton).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_NEAR(result.objective, 0.5 * newton.dot(h * newton) + q.dot(newton), 1e-10);
}

TEST(BoundedInputQp, MatchesTheBestActiveSetOnRandomBoxAndChangeBoundedProblems) {
  std::mt19937 random(11);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const int nu = 2, horizon = 2, n = nu * horizon;
  BoundedInputQp qp(nu, horizon);
  int with_active_bounds = 0;
  for (int trial = 0; trial < 20; ++trial) {
    SCOPED_TRACE(trial);
    const Eigen::MatrixXd h = random_positive_definite(n, &random);
    Eigen::VectorXd q(n);
    for (int i = 0; i < n; ++i) q[i] = 3.0 * uniform(random);
    InputBounds bounds;
    bounds.lower = Eigen::Vector2d(-0.5 + 0.3 * uniform(random), -0.4);
    bounds.upper = Eigen::Vector2d(0.6, 0.5 + 0.3 * uniform(random));
    bounds.max_step = Eigen::Vector2d(0.3 + 0.1 * uniform(random), 0.35);
    const Eigen::Vector2d previous(0.2 * uniform(random), 0.2 * uniform(random));
    double expected_objective = 0.0;
    const Eigen::VectorXd expected =
        enumerated_optimum(h, q, dense_constraints(bounds, previous, nu, horizon), &expected_objective);
    ASSERT_EQ(expected.size(), n);
    Eigen::VectorXd z = Eigen::VectorXd::Constant(n, 2.0);  // outside every box: an infeasible start
    const BoundedInputQp::Result result = qp.solve(h, q, bounds, previous, {}, z);
    ASSERT_TRUE(result.converged) << result.reason;
    EXPECT_LE((z - expected).lpNorm<Eigen::Infinity>(), 1e-6);
    EXPECT_NEAR(result.objective, expected_objective, 1e-8 * (1.0 + std::abs(expected_objective)));
    const Eigen::VectorXd unconstrained = -h.llt().solve(q);
    if ((unconstrained - expected).norm() > 1e-6) ++with_active_bounds;
  }
  // The draws must exercise the bounds, or the test says nothing about them.
  EXPECT_GE(with_active_bounds, 10);
}

TEST(BoundedInputQp, KeepsEveryInputInsideItsBoxAndChangeBoundsAtTheAnswer) {
  // Each input on its own (H = I), pulled far up (its free optimum is 50): it must climb by its
  // change bound each step until its box stops it.
  const int nu = 3, horizon = 10, n = nu * horizon;
  const Eigen::MatrixXd h = Eigen::MatrixXd::Identity(n, n);
  const Eigen::VectorXd q = Eigen::VectorXd::Constant(n, -50.0);
  InputBounds bounds;
  bounds.lower = Eigen::Vector3d(-1.0, -1.0, -kInf);
  bounds.upper = Eigen::Vector3d(1.0, 2.0, kInf);
  bounds.max_step = Eigen::Vector3d(0.1, kInf, 0.2);
  const Eigen::Vector3d previous(0.0, 0.5, -0.3);
  BoundedInputQp qp(nu, horizon);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(n);
  ASSERT_TRUE(qp.solve(h, q, bounds, previous, {}, z).converged);
  const Eigen::Map<const Eigen::MatrixXd> inputs(z.data(), nu, horizon);
  for (int k = 0; k < horizon; ++k) {
    const Eigen::Vector3d before = k == 0 ? Eigen::Vector3d(previous) : Eigen::Vector3d(inputs.col(k - 1));
    for (int i = 0; i < nu; ++i) {
      EXPECT_GE(inputs(i, k), bounds.lower[i] - 1e-8);
      EXPECT_LE(inputs(i, k), bounds.upper[i] + 1e-8);
      EXPECT_LE(std::abs(inputs(i, k) - before[i]), bounds.max_step[i] + 1e-8);
    }
  }
  for (int k = 0; k < horizon; ++k) {
    EXPECT_NEAR(inputs(0, k), 0.1 * (k + 1), 1e-7);           // 0.1 per step up to its box, 1.0
    EXPECT_NEAR(inputs(1, k), 2.0, 1e-7);                     // no change bound: at its box at once
    EXPECT_NEAR(inputs(2, k), -0.3 + 0.2 * (k + 1), 1e-7);    // no box: 0.2 per step for ever
  }
}

TEST(BoundedInputQp, RefusesWrongSizesAndNonFiniteDataWithoutTouchingTheAnswer) {
  BoundedInputQp qp(2, 3);
  const Eigen::MatrixXd h = Eigen::MatrixXd::Identity(6, 6);
  Eigen::VectorXd q = Eigen::VectorXd::Ones(6);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(6);
  EXPECT_FALSE(qp.solve(Eigen::MatrixXd::Identity(5, 5), q, {}, Eigen::VectorXd::Zero(2), {}, z).converged);
  InputBounds wrong;
  wrong.lower = Eigen::VectorXd::Zero(3);
  EXPECT_STREQ(qp.solve(h, q, wrong, Eigen::VectorXd::Zero(2), {}, z).reason, "wrong sizes");
  q[2] = std::nan("");
  EXPECT_FALSE(qp.solve(h, q, {}, Eigen::VectorXd::Zero(2), {}, z).converged);
  EXPECT_TRUE(z.isZero());
  EXPECT_THROW(BoundedInputQp(0, 3), ConfigError);
  EXPECT_THROW(BoundedInputQp(2, 0), ConfigError);
}

}  // namespace
}  // namespace swerve
