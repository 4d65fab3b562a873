// The learnt stage curvature: damped BFGS keeps each block positive semi-definite whatever the
// pairs (negative curvature included) and meets the secant condition where the curvature is
// positive; on a quadratic it learns the exact Hessian from enough pairs, and so it does for the
// stage Lagrangian of a problem whose wear is quadratic, from successive linearisations.
#include "swerve/ocp/stage_quasi_newton.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <random>
#include <vector>

#include "support/linear_models.hpp"

namespace swerve {
namespace {

double smallest_eigenvalue(const Eigen::MatrixXd& b) {
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (b + b.transpose())).eigenvalues().minCoeff();
}

TEST(StageQuasiNewton, DampedBfgsStaysPositiveSemiDefiniteOnPairsOfAnyCurvature) {
  std::mt19937 random(2);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = 7;
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd s(n), y(n), bs(n), r(n);
  // An indefinite "true" Hessian with entries of very different scales.
  Eigen::MatrixXd truth = Eigen::MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i) truth(i, i) = (i % 3 == 0 ? -1.0 : 1.0) * std::pow(10.0, i - 3);
  double worst = 0.0;
  for (int pair = 0; pair < 400; ++pair) {
    for (int i = 0; i < n; ++i) s[i] = normal(random) * std::pow(10.0, (pair % 5) - 3);
    y = truth * s;
    StageQuasiNewton::damped_bfgs(&b, s, y, &bs, &r);
    worst = std::min(worst, smallest_eigenvalue(b) / std::max(1.0, b.norm()));
  }
  EXPECT_GE(worst, -1e-10);
}

TEST(StageQuasiNewton, DampedBfgsMeetsTheSecantConditionWherePairsCurveUpwards) {
  const Eigen::Vector3d s(0.1, -0.2, 0.05);
  Eigen::Matrix3d truth;
  truth << 4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0;
  const Eigen::VectorXd y = truth * s;
  Eigen::MatrixXd b = Eigen::MatrixXd::Identity(3, 3);
  Eigen::VectorXd bs(3), r(3);
  StageQuasiNewton::damped_bfgs(&b, s, y, &bs, &r);
  EXPECT_LE((b * s - y).cwiseAbs().maxCoeff(), 1e-12);
  // From zero (no curvature known) too, and a negative-curvature pair then leaves it unchanged.
  Eigen::MatrixXd from_zero = Eigen::MatrixXd::Zero(3, 3);
  StageQuasiNewton::damped_bfgs(&from_zero, s, y, &bs, &r);
  EXPECT_LE((from_zero * s - y).cwiseAbs().maxCoeff(), 1e-12);
  Eigen::MatrixXd untouched = Eigen::MatrixXd::Zero(3, 3);
  StageQuasiNewton::damped_bfgs(&untouched, s, -y, &bs, &r);
  EXPECT_TRUE(untouched.isZero(0.0));
}

TEST(StageQuasiNewton, LearnsTheExactHessianOfAQuadraticFromPairsSpanningItsSpace) {
  std::mt19937 random(4);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = 5;
  Eigen::MatrixXd root(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) root(i, j) = normal(random);
  }
  const Eigen::MatrixXd truth = root * root.transpose() + Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd s(n), y(n), bs(n), r(n);
  // BFGS with exact line searches on a quadratic recovers it in n conjugate steps; random pairs get
  // there over more of them.
  for (int pair = 0; pair < 200; ++pair) {
    for (int i = 0; i < n; ++i) s[i] = normal(random);
    y = truth * s;
    StageQuasiNewton::damped_bfgs(&b, s, y, &bs, &r);
  }
  EXPECT_LE((b - truth).norm(), 1e-6 * truth.norm());
}

TEST(StageQuasiNewton, LearnsTheStageLagrangianHessianOfTheDoubleIntegratorFromSuccessiveLinearisations) {
  // The double integrator's stage wear is s dt |u|^2 and its dynamics are linear, so the stage
  // Lagrangian's Hessian over (x, u) is 2 lambda s dt on u's block and zero elsewhere.
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 4);
  OcpDerivatives derivatives(problem);
  StageQuasiNewton memory(problem);
  std::mt19937 random(6);
  std::normal_distribution<double> normal(0.0, 0.3);
  Eigen::MatrixXd inputs = Eigen::MatrixXd::Zero(3, 4), states(6, 5), gradient(3, 4);
  for (int solve = 0; solve < 200; ++solve) {
    memory.begin_solve();
    for (int i = 0; i < inputs.size(); ++i) inputs.data()[i] = normal(random);
    derivatives.cost_and_gradient(problem, inputs, states, gradient);
    memory.update(problem, derivatives, states, inputs, false);
  }
  const double expected = 2.0 * problem.weights().wear * model.wear_scale() * problem.dt();
  for (int k = 0; k < 4; ++k) {
    const Eigen::MatrixXd& b = memory.block(k);
    EXPECT_LE((b.bottomRightCorner(3, 3) - expected * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-6);
    EXPECT_LE(b.topLeftCorner(6, 6).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(StageQuasiNewton, AfterARecedingHorizonShiftEachStagePairsWithTheLastSolvesStageAhead) {
  // The double integrator's plan moved on by one step is the same points, stage k now where stage
  // k + 1 was: each stage's pair is then empty (s = 0) and its curvature the one it takes over
  // unchanged. Paired with its own index instead, every stage would see a non-zero s and change.
  const testing::DoubleIntegratorModel model(0.5);
  OcpProblem problem = testing::make_lq_problem(model, 5);
  OcpDerivatives derivatives(problem);
  StageQuasiNewton memory(problem);
  std::mt19937 random(8);
  std::normal_distribution<double> normal(0.0, 0.3);
  Eigen::MatrixXd inputs(3, 5), states(6, 6), gradient(3, 5);
  for (int solve = 0; solve < 6; ++solve) {
    memory.begin_solve();
    for (int i = 0; i < inputs.size(); ++i) inputs.data()[i] = normal(random);
    derivatives.cost_and_gradient(problem, inputs, states, gradient);
    memory.update(problem, derivatives, states, inputs, false);
  }
  std::vector<Eigen::MatrixXd> before;
  for (int k = 0; k < 5; ++k) before.push_back(memory.block(k));
  problem.set_initial_state(states.col(1));
  Eigen::MatrixXd shifted(3, 5);
  shifted << inputs.rightCols(4), inputs.col(4);
  memory.begin_solve();
  derivatives.cost_and_gradient(problem, shifted, states, gradient);
  memory.update(problem, derivatives, states, shifted, false);
  for (int k = 0; k + 1 < 5; ++k) {
    EXPECT_TRUE(before[static_cast<std::size_t>(k) + 1].isZero(0.0) == false);
    EXPECT_EQ(memory.block(k), before[static_cast<std::size_t>(k) + 1]) << "stage " << k;
  }
}

}  // namespace
}  // namespace swerve
