// The condensed Gauss-Newton Hessian against independent truth: the exact Hessian of a linear-
// quadratic problem (and its one-step optimum), J^T J of the cost's stacked residuals by central
// differences through rollouts on the swerve problem, the wear's curvature from central differences
// of the stage wear, and the stage-wise (multiple-shooting) KKT system of the same Gauss-Newton QP,
// which a Riccati recursion would solve, giving the same step; its cross term with the start (the
// real-time iteration's feedback) against that KKT system with the start moved, and against the
// gradient's derivative where the Gauss-Newton model is exact.
#include "swerve/ocp/condensed_gauss_newton.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <vector>

#include "support/linear_models.hpp"
#include "support/one_off_steps.hpp"
#include "support/swerve_problems.hpp"

namespace swerve {
namespace {

using testing::DoubleIntegratorModel;

// The swerve turning problem with every residual of the cost active: pose (pseudo-Huber), twist,
// a tube that binds on the later stages, effort, rate, a state effort on the steering angles, wear.
struct EveryTermProblem {
  testing::SwerveTestProblem s{testing::SwerveScene::kTurn};
  OcpProblem problem;
  EveryTermProblem() : problem(s.model, 8, 0.05, weights(s), s.problem.bounds()) {
    problem.set_initial_state(s.problem.initial_state());
    problem.set_previous_input(s.problem.previous_input());
    for (int k = 1; k <= problem.horizon(); ++k) {
      problem.set_reference(k, s.problem.reference_poses().col(k - 1), s.problem.reference_twists().col(k - 1));
      if (k > 4) problem.set_tube(k, 0.01, 0.02);
    }
  }
  static CostWeights weights(const testing::SwerveTestProblem& s) {
    CostWeights w = testing::SwerveTestProblem::weights(testing::SwerveScene::kTurn);
    w.pose_huber_width = 0.02;
    w.tube_penalty = 50.0;
    w.state_effort = Eigen::VectorXd::Zero(s.model.state_size());
    w.state_effort.tail(s.model.state_size() - 6).setConstant(0.3);
    return w;
  }
  Eigen::MatrixXd inputs(unsigned seed) const {
    Eigen::MatrixXd u = s.jittered_inputs(0.1, seed).leftCols(problem.horizon());
    problem.project(u);
    return u;
  }
};

// `problem` with its start and last input moved by t times (dx0, du_previous): what a measured start
// poses to a plan linearised from `problem`'s.
OcpProblem moved_start(const OcpProblem& problem, double t, const Eigen::VectorXd& dx0, const Eigen::Vector3d& du_previous) {
  OcpProblem moved = problem;
  moved.set_initial_state(problem.initial_state() + t * dx0);
  moved.set_previous_input(problem.previous_input() + t * du_previous);
  return moved;
}

// Every least-squares residual of the cost, stacked stage by stage, from a rollout of `inputs`.
Eigen::VectorXd stacked_residuals(const OcpProblem& problem, const Eigen::MatrixXd& inputs) {
  const int horizon = problem.horizon();
  const int nu = problem.input_size();
  const Eigen::Index effort_rows = problem.state_effort_index().size();
  const Eigen::Index per_stage = OcpProblem::kTrackingResiduals + effort_rows + 2 * nu;
  Eigen::MatrixXd states(problem.state_size(), horizon + 1);
  testing::evaluate_once(problem, inputs, states);
  Eigen::VectorXd r(per_stage * horizon);
  for (int k = 0; k < horizon; ++k) {
    OcpProblem::TrackingResiduals tracking;
    problem.tracking_residuals(k, states.col(k + 1), &tracking);
    auto stage = r.segment(k * per_stage, per_stage);
    stage.head<OcpProblem::kTrackingResiduals>() = tracking;
    for (Eigen::Index j = 0; j < effort_rows; ++j) {
      stage[OcpProblem::kTrackingResiduals + j] =
          problem.state_effort_root()[j] * states(problem.state_effort_index()[j], k + 1);
    }
    const Eigen::VectorXd before = k == 0 ? problem.previous_input() : Eigen::VectorXd(inputs.col(k - 1));
    stage.segment(OcpProblem::kTrackingResiduals + effort_rows, nu) = problem.effort_root().cwiseProduct(inputs.col(k));
    stage.tail(nu) = problem.rate_root().cwiseProduct(inputs.col(k) - before);
  }
  return r;
}

// Each stage's wear as a rollout gives it.
Eigen::VectorXd stage_wear_of(const OcpProblem& problem, const Eigen::MatrixXd& inputs) {
  const std::unique_ptr<PredictionData> data = problem.model().create_data();
  Eigen::MatrixXd states(problem.state_size(), problem.horizon() + 1);
  Eigen::VectorXd costs(problem.horizon()), wear(problem.horizon());
  problem.rollout(*data, inputs, 0, states, costs, wear.data());
  return wear;
}

// Central differences of f over the stacked inputs: column j = df/dU_j.
template <typename F>
Eigen::MatrixXd central_differences(const Eigen::MatrixXd& inputs, F f) {
  const Eigen::Index n = inputs.size();
  Eigen::MatrixXd jacobian;
  for (Eigen::Index j = 0; j < n; ++j) {
    Eigen::MatrixXd plus = inputs, minus = inputs;
    const double h = 1e-6;
    plus.data()[j] += h;
    minus.data()[j] -= h;
    const Eigen::VectorXd column = (f(plus) - f(minus)) / (2.0 * h);
    if (jacobian.size() == 0) jacobian.resize(column.size(), n);
    jacobian.col(j) = column;
  }
  return jacobian;
}

// Linearises `problem` along `inputs` and returns the condensed Hessian; the gradient in *gradient.
Eigen::MatrixXd condensed_hessian(const OcpProblem& problem, const Eigen::MatrixXd& inputs, bool wear_curvature,
                                  OcpDerivatives* derivatives, Eigen::MatrixXd* states, Eigen::MatrixXd* gradient) {
  states->resize(problem.state_size(), problem.horizon() + 1);
  gradient->resize(problem.input_size(), problem.horizon());
  EXPECT_TRUE(std::isfinite(derivatives->cost_and_gradient(problem, inputs, *states, *gradient)));
  CondensedGaussNewton condensed(problem);
  Eigen::MatrixXd hessian(condensed.size(), condensed.size());
  EXPECT_TRUE(condensed.hessian(problem, *derivatives, *states, wear_curvature, hessian));
  return hessian;
}

TEST(CondensedGaussNewton, IsTheExactHessianOfALinearQuadraticProblemSoOneNewtonStepReachesItsOptimum) {
  const DoubleIntegratorModel model(0.0);
  const OcpProblem problem = testing::make_lq_problem(model, 6);
  OcpDerivatives derivatives(problem);
  const Eigen::MatrixXd start = Eigen::MatrixXd::Constant(3, 6, 0.3);
  Eigen::MatrixXd states, gradient;
  const Eigen::MatrixXd hessian = condensed_hessian(problem, start, true, &derivatives, &states, &gradient);
  const Eigen::VectorXd g = Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size());
  const Eigen::VectorXd step = -hessian.llt().solve(g);
  const Eigen::MatrixXd reached = start + Eigen::Map<const Eigen::MatrixXd>(step.data(), 3, 6);
  EXPECT_LE((reached - testing::double_integrator_optimum(problem, model)).cwiseAbs().maxCoeff(), 1e-9);
  // And the Hessian is the gradient's own derivative (central differences of the exact gradient).
  OcpDerivatives probe(problem);
  const Eigen::MatrixXd expected = central_differences(start, [&](const Eigen::MatrixXd& u) {
    Eigen::MatrixXd x(6, 7), g_u(3, 6);
    probe.cost_and_gradient(problem, u, x, g_u);
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g_u.data(), g_u.size()));
  });
  EXPECT_LE((hessian - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
}

TEST(CondensedGaussNewton, IsJTransposeJOfEveryResidualOfTheSwerveCostByCentralDifferences) {
  const EveryTermProblem p;
  const Eigen::MatrixXd inputs = p.inputs(4);
  OcpDerivatives derivatives(p.problem);
  Eigen::MatrixXd states, gradient;
  const Eigen::MatrixXd hessian = condensed_hessian(p.problem, inputs, false, &derivatives, &states, &gradient);
  const Eigen::MatrixXd jacobian =
      central_differences(inputs, [&](const Eigen::MatrixXd& u) { return stacked_residuals(p.problem, u); });
  const Eigen::MatrixXd expected = jacobian.transpose() * jacobian;
  EXPECT_LE((hessian - expected).cwiseAbs().maxCoeff(), 1e-5 * expected.cwiseAbs().maxCoeff());
  // The tube and the state effort took part (else the comparison says nothing about them).
  const Eigen::VectorXd r = stacked_residuals(p.problem, inputs);
  EXPECT_GT(p.problem.state_effort_index().size(), 0);
  const Eigen::Index per_stage = OcpProblem::kTrackingResiduals + p.problem.state_effort_index().size() + 6;
  double tube = 0.0;
  for (int k = 0; k < p.problem.horizon(); ++k) tube += std::abs(r[k * per_stage + OcpProblem::kTubeResidual]);
  EXPECT_GT(tube, 0.0);
}

TEST(CondensedGaussNewton, AddsEachStagesWearCurvatureGradWGradWOverTwoW) {
  const EveryTermProblem p;
  const Eigen::MatrixXd inputs = p.inputs(6);
  OcpDerivatives derivatives(p.problem);
  Eigen::MatrixXd states, gradient;
  const Eigen::MatrixXd without = condensed_hessian(p.problem, inputs, false, &derivatives, &states, &gradient);
  const Eigen::MatrixXd with = condensed_hessian(p.problem, inputs, true, &derivatives, &states, &gradient);
  const Eigen::VectorXd wear = stage_wear_of(p.problem, inputs);
  const Eigen::MatrixXd wear_jacobian =
      central_differences(inputs, [&](const Eigen::MatrixXd& u) { return stage_wear_of(p.problem, u); });
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(without.rows(), without.cols());
  for (int k = 0; k < p.problem.horizon(); ++k) {
    ASSERT_GT(wear[k], CondensedGaussNewton::kWearFloor);
    const Eigen::VectorXd g = wear_jacobian.row(k).transpose();
    expected += p.problem.weights().wear / (2.0 * wear[k]) * g * g.transpose();
  }
  EXPECT_GT(expected.norm(), 0.0);
  EXPECT_LE((with - without - expected).cwiseAbs().maxCoeff(), 1e-4 * expected.cwiseAbs().maxCoeff());
}

// The Gauss-Newton QP of the plan `inputs` (rolled out to `states`, linearised in `derivatives`)
// written stage-wise, as multiple shooting (and a Riccati recursion) sees it, and solved densely:
// variables du_0..du_{N-1} and dx_0..dx_N, the start fixed at dx_0 = dx0, the linearised dynamics
// dx_{k+1} = A_k dx_k + B_k du_k as equality rows, each stage's residuals linearised in its own
// variables, the wear as W + g^T dz + lambda (g^T dz)^2 / (4 W), the learnt block B_k (if any) on
// dz_k = (dx_k, du_k), and the last input moved by du_previous. Returns du (nu N).
Eigen::VectorXd stage_wise_step(const OcpProblem& problem, const OcpDerivatives& derivatives,
                                const Eigen::MatrixXd& states, const Eigen::MatrixXd& inputs, const Eigen::VectorXd& dx0,
                                const Eigen::VectorXd& du_previous, const StageQuasiNewton* learnt = nullptr) {
  const int horizon = problem.horizon(), nx = problem.state_size(), nu = problem.input_size();
  const int n_u = nu * horizon, n_x = nx * (horizon + 1), n = n_u + n_x;
  const auto u_index = [&](int k) { return k * nu; };           // du_k
  const auto x_index = [&](int k) { return n_u + k * nx; };     // dx_k, k >= 0
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd equalities = Eigen::MatrixXd::Zero(n_x, n);
  Eigen::VectorXd equality_rhs = Eigen::VectorXd::Zero(n_x);
  equalities.block(0, x_index(0), nx, nx).setIdentity();  // dx_0 = dx0
  equality_rhs.head(nx) = dx0;
  const double lambda = problem.weights().wear;
  for (int k = 0; k < horizon; ++k) {
    // Dynamics: dx_{k+1} - A_k dx_k - B_k du_k = 0.
    const int row = (k + 1) * nx;
    equalities.block(row, x_index(k + 1), nx, nx).setIdentity();
    equalities.block(row, x_index(k), nx, nx) = -derivatives.a(k);
    equalities.block(row, u_index(k), nx, nu) = -derivatives.b(k);
    // Tracking at x_{k+1}.
    OcpProblem::TrackingResiduals r;
    OcpProblem::TrackingJacobian j;
    problem.tracking_residuals(k, states.col(k + 1), &r, &j);
    h.block(x_index(k + 1), x_index(k + 1), 6, 6) += j.transpose() * j;
    q.segment(x_index(k + 1), 6) += j.transpose() * r;
    for (Eigen::Index e = 0; e < problem.state_effort_index().size(); ++e) {
      const int state = x_index(k + 1) + problem.state_effort_index()[e];
      const double root = problem.state_effort_root()[e];
      h(state, state) += root * root;
      q[state] += root * root * states(problem.state_effort_index()[e], k + 1);
    }
    // Effort and rate on the inputs.
    const Eigen::VectorXd before =
        k == 0 ? Eigen::VectorXd(problem.previous_input() + du_previous) : Eigen::VectorXd(inputs.col(k - 1));
    for (int i = 0; i < nu; ++i) {
      const double effort = problem.effort_root()[i] * problem.effort_root()[i];
      const double rate = problem.rate_root()[i] * problem.rate_root()[i];
      const int a = u_index(k) + i;
      h(a, a) += effort + rate;
      q[a] += effort * inputs(i, k) + rate * (inputs(i, k) - before[i]);
      if (k > 0) {
        const int b = u_index(k - 1) + i;
        h(b, b) += rate;
        h(a, b) -= rate;
        h(b, a) -= rate;
        q[b] -= rate * (inputs(i, k) - before[i]);
      }
    }
    // Wear and the learnt block over z_k = (dx_k, du_k).
    const Eigen::VectorXd& wear_gradient = derivatives.wear_gradient(k);
    Eigen::VectorXd wear_row = Eigen::VectorXd::Zero(n);
    wear_row.segment(x_index(k), nx) = wear_gradient.head(nx);
    wear_row.segment(u_index(k), nu) = wear_gradient.tail(nu);
    q += lambda * wear_row;
    h += lambda / (2.0 * std::max(derivatives.wear(k), CondensedGaussNewton::kWearFloor)) * wear_row *
         wear_row.transpose();
    if (learnt != nullptr) {
      const Eigen::MatrixXd& block = learnt->block(k);
      h.block(x_index(k), x_index(k), nx, nx) += block.topLeftCorner(nx, nx);
      h.block(x_index(k), u_index(k), nx, nu) += block.topRightCorner(nx, nu);
      h.block(u_index(k), x_index(k), nu, nx) += block.bottomLeftCorner(nu, nx);
      h.block(u_index(k), u_index(k), nu, nu) += block.bottomRightCorner(nu, nu);
    }
  }
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + n_x, n + n_x);
  kkt.topLeftCorner(n, n) = h;
  kkt.topRightCorner(n, n_x) = equalities.transpose();
  kkt.bottomLeftCorner(n_x, n) = equalities;
  Eigen::VectorXd rhs(n + n_x);
  rhs << -q, equality_rhs;
  return kkt.partialPivLu().solve(rhs).head(n_u);
}

TEST(CondensedGaussNewton, ItsStepIsTheSolutionOfTheStageWiseKktSystemOfTheSameQp) {
  const EveryTermProblem p;
  const OcpProblem& problem = p.problem;
  const Eigen::MatrixXd inputs = p.inputs(8);
  OcpDerivatives derivatives(problem);
  Eigen::MatrixXd states, gradient;
  const Eigen::MatrixXd hessian = condensed_hessian(problem, inputs, true, &derivatives, &states, &gradient);
  const Eigen::VectorXd g = Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size());
  const Eigen::VectorXd condensed_step = -hessian.llt().solve(g);
  const Eigen::VectorXd stage_wise = stage_wise_step(problem, derivatives, states, inputs,
                                                     Eigen::VectorXd::Zero(problem.state_size()),
                                                     Eigen::VectorXd::Zero(problem.input_size()));
  EXPECT_LE((stage_wise - condensed_step).cwiseAbs().maxCoeff(), 1e-8 * (1.0 + condensed_step.cwiseAbs().maxCoeff()));
}

TEST(CondensedGaussNewton, ItsStartProductMovesTheStepToTheStageWiseQpOfAMovedStartAndLastInput) {
  // The real-time iteration's feedback: the plan linearised from one start, the QP posed for
  // another start and last input. With every cost term and learnt blocks taking part.
  const EveryTermProblem p;
  const OcpProblem& problem = p.problem;
  const Eigen::MatrixXd inputs = p.inputs(8);
  OcpDerivatives derivatives(problem);
  StageQuasiNewton learnt(problem);
  Eigen::MatrixXd states(problem.state_size(), problem.horizon() + 1), gradient(3, problem.horizon());
  ASSERT_TRUE(std::isfinite(derivatives.cost_and_gradient(problem, p.inputs(9), states, gradient)));
  learnt.update(problem, derivatives, states, p.inputs(9), true);
  ASSERT_TRUE(std::isfinite(derivatives.cost_and_gradient(problem, inputs, states, gradient)));
  learnt.update(problem, derivatives, states, inputs, true);
  double learnt_size = 0.0;
  for (int k = 0; k < problem.horizon(); ++k) learnt_size += learnt.block(k).norm();
  ASSERT_GT(learnt_size, 0.0);  // the blocks take part

  CondensedGaussNewton condensed(problem);
  Eigen::MatrixXd hessian(condensed.size(), condensed.size());
  ASSERT_TRUE(condensed.hessian(problem, derivatives, states, true, hessian, &learnt));
  Eigen::VectorXd dx0(problem.state_size());
  for (Eigen::Index i = 0; i < dx0.size(); ++i) dx0[i] = 0.01 * std::sin(1.0 + 2.0 * static_cast<double>(i));
  const Eigen::Vector3d du_previous(0.03, -0.02, 0.05);
  Eigen::VectorXd product(condensed.size());
  ASSERT_TRUE(condensed.start_product(problem, derivatives, inputs, states, true, dx0, du_previous, product, &learnt));
  const Eigen::VectorXd g = Eigen::Map<const Eigen::VectorXd>(gradient.data(), gradient.size());
  const Eigen::VectorXd moved_step = -hessian.llt().solve(g + product);
  const Eigen::VectorXd stage_wise = stage_wise_step(problem, derivatives, states, inputs, dx0, du_previous, &learnt);
  EXPECT_GT((moved_step + hessian.llt().solve(g)).norm(), 1e-3 * moved_step.norm());  // the move matters
  EXPECT_LE((stage_wise - moved_step).cwiseAbs().maxCoeff(), 1e-8 * (1.0 + moved_step.cwiseAbs().maxCoeff()));
}

TEST(CondensedGaussNewton, ItsCostChangeHasTheCostsExactSlopeInTheStartWithEveryTerm) {
  // Away from zero residuals the model's curvature is approximate, but its slope is the cost's
  // gradient in the start and last input, exactly: through the costate after stage 0, stage 0's
  // wear and the rate. The two directions' changes give the slope apart from the curvature.
  const EveryTermProblem p;
  const OcpProblem& problem = p.problem;
  ASSERT_GT(problem.weights().wear, 0.0);
  const Eigen::MatrixXd inputs = p.inputs(8);
  OcpDerivatives derivatives(problem);
  Eigen::MatrixXd states(problem.state_size(), problem.horizon() + 1), gradient(3, problem.horizon());
  ASSERT_TRUE(std::isfinite(derivatives.cost_and_gradient(problem, inputs, states, gradient)));
  CondensedGaussNewton condensed(problem);
  Eigen::VectorXd dx0(problem.state_size());
  for (Eigen::Index i = 0; i < dx0.size(); ++i) dx0[i] = 0.01 * std::sin(1.0 + 2.0 * static_cast<double>(i));
  const Eigen::Vector3d du_previous(0.03, -0.02, 0.05);
  const auto moved_by = [&](double t) { return moved_start(problem, t, dx0, du_previous); };
  Eigen::VectorXd product(condensed.size());
  double change = 0.0, change_back = 0.0;
  ASSERT_TRUE(condensed.start_product(moved_by(1.0), derivatives, inputs, states, true, dx0, du_previous, product,
                                      nullptr, &change));
  ASSERT_TRUE(condensed.start_product(moved_by(-1.0), derivatives, inputs, states, true, -dx0, -du_previous, product,
                                      nullptr, &change_back));
  const auto cost_at = [&](double t) {
    const OcpProblem moved = moved_by(t);
    Eigen::MatrixXd x(moved.state_size(), problem.horizon() + 1);
    return testing::evaluate_once(moved, inputs, x).total();
  };
  const double step = 1e-5;
  const double first = (cost_at(step) - cost_at(-step)) / (2.0 * step);
  EXPECT_GT(std::abs(first), 1e-2);
  EXPECT_NEAR(0.5 * (change - change_back), first, 1e-6 * (1.0 + std::abs(first)));
}

TEST(CondensedGaussNewton, ItsStartProductAndCostChangeAreTheCostsDerivativesInTheStartWhereEveryResidualVanishes) {
  // Where the tracking residuals are zero and there is no wear, Gauss-Newton's cross term is the
  // exact second derivative (the left-out terms are residuals and costates times curvatures), so
  // it must equal the gradient's central difference along a change of the start and last input.
  testing::SwerveTestProblem s(testing::SwerveScene::kTurn);
  CostWeights weights = testing::SwerveTestProblem::weights(testing::SwerveScene::kTurn);
  weights.wear = 0.0;
  OcpProblem problem(s.model, 10, 0.05, weights, s.problem.bounds());
  problem.set_initial_state(s.problem.initial_state());
  problem.set_previous_input(s.problem.previous_input());
  Eigen::MatrixXd inputs = s.jittered_inputs(0.1, 3).leftCols(10);
  problem.project(inputs);
  Eigen::MatrixXd states(problem.state_size(), 11), gradient(3, 10);
  testing::evaluate_once(problem, inputs, states);
  for (int k = 1; k <= 10; ++k) problem.set_reference(k, states.col(k).head<3>(), states.col(k).segment<3>(3));
  OcpDerivatives derivatives(problem);
  ASSERT_TRUE(std::isfinite(derivatives.cost_and_gradient(problem, inputs, states, gradient)));
  CondensedGaussNewton condensed(problem);
  Eigen::VectorXd dx0 = Eigen::VectorXd::Zero(problem.state_size());
  dx0.head<6>() << 0.02, -0.01, 0.03, 0.05, -0.04, 0.02;
  const Eigen::Vector3d du_previous(0.03, -0.02, 0.05);
  const auto moved_by = [&](double t) { return moved_start(problem, t, dx0, du_previous); };
  Eigen::VectorXd product(condensed.size()), product_back(condensed.size());
  double change = 0.0, change_back = 0.0;
  ASSERT_TRUE(condensed.start_product(moved_by(1.0), derivatives, inputs, states, false, dx0, du_previous, product,
                                      nullptr, &change));
  ASSERT_TRUE(condensed.start_product(moved_by(-1.0), derivatives, inputs, states, false, -dx0, -du_previous,
                                      product_back, nullptr, &change_back));

  const double h = 1e-5;
  const auto gradient_at = [&](double t) {
    const OcpProblem moved = moved_by(t);
    OcpDerivatives probe(moved);
    Eigen::MatrixXd x(moved.state_size(), 11), g(3, 10);
    probe.cost_and_gradient(moved, inputs, x, g);
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(g.data(), g.size()));
  };
  const Eigen::VectorXd expected = (gradient_at(h) - gradient_at(-h)) / (2.0 * h);
  EXPECT_GT(expected.norm(), 1e-3);
  EXPECT_LE((product - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  EXPECT_LE((product_back + expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  // The predicted cost change is slope + curvature / 2 each way, so the two give the slope and the
  // curvature apart: the cost's first and second derivatives along the change (zero residuals:
  // J^T J is all of the curvature), by central differences of rollouts.
  const auto cost_at = [&](double t) {
    const OcpProblem moved = moved_by(t);
    Eigen::MatrixXd x(moved.state_size(), 11);
    return testing::evaluate_once(moved, inputs, x).total();
  };
  const double step = 1e-3;
  const double first = (cost_at(step) - cost_at(-step)) / (2.0 * step);
  const double second = (cost_at(step) - 2.0 * cost_at(0.0) + cost_at(-step)) / (step * step);
  EXPECT_GT(second, 1e-3);
  EXPECT_GT(std::abs(first), 1e-3);  // the rate term's slope at least
  EXPECT_NEAR(0.5 * (change - change_back), first, 1e-5 * (std::abs(first) + second));
  EXPECT_NEAR(change + change_back, second, 1e-4 * second);
}

}  // namespace
}  // namespace swerve
