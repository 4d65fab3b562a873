// The OCP's single-shooting gradient (adjoint recursion over the models' exact Jacobians): zero at
// the closed-form optimum of the linear-quadratic problem, equal to central finite differences of
// the rollout cost on the swerve problem, and the same cost OcpProblem::rollout reports.
#include "swerve/ocp/ocp_derivatives.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "support/two_threads.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/ocp/twist_prediction_model.hpp"
#include "support/one_off_steps.hpp"

namespace swerve {
namespace {

TEST(OcpDerivatives, GradientVanishesAtTheClosedFormOptimum) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 6);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  OcpDerivatives derivatives(problem);
  Eigen::MatrixXd states(6, 7), gradient(3, 6);
  const double cost = derivatives.cost_and_gradient(problem, optimum, states, gradient);
  EXPECT_LT(gradient.cwiseAbs().maxCoeff(), 1e-9 * (1.0 + cost)) << gradient;
  // Away from it the gradient is not zero (so the check above can fail).
  const Eigen::MatrixXd off = optimum.array() + 0.1;
  derivatives.cost_and_gradient(problem, off, states, gradient);
  EXPECT_GT(gradient.cwiseAbs().maxCoeff(), 1e-3);
}

TEST(OcpDerivatives, SwerveGradientMatchesCentralFiniteDifferencesOfTheRolloutCost) {
  testing::SwerveTestProblem s(testing::SwerveScene::kTurn, 10, std::numeric_limits<double>::infinity());
  const OcpProblem& problem = s.problem;
  const TwistPredictionModel& model = s.model;
  const Eigen::MatrixXd inputs = s.jittered_inputs(0.05, 7);
  OcpDerivatives derivatives(problem);
  Eigen::MatrixXd states(model.state_size(), 11), gradient(3, 10), fd(3, 10);
  Eigen::VectorXd stage_costs(10);
  const double cost = derivatives.cost_and_gradient(problem, inputs, states, gradient);
  EXPECT_NEAR(cost, testing::rollout_once(problem, inputs, 0, states, stage_costs), 1e-12 * cost);
  for (int k = 0; k < 10; ++k) {
    for (int i = 0; i < 3; ++i) {
      Eigen::MatrixXd plus = inputs, minus = inputs;
      const double h = 1e-6;
      plus(i, k) += h;
      minus(i, k) -= h;
      fd(i, k) = (testing::rollout_once(problem, plus, 0, states, stage_costs) - testing::rollout_once(problem, minus, 0, states, stage_costs)) / (2 * h);
    }
  }
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 1.0);
  EXPECT_LT((gradient - fd).cwiseAbs().maxCoeff(), 1e-5 * scale) << "adjoint\n" << gradient << "\nfd\n" << fd;
}

TEST(OcpDerivatives, RefusesAModelWithoutJacobians) {
  const testing::ModelWithoutJacobians model;
  const OcpProblem problem(model, 3, 0.1, CostWeights{}, InputBounds{});
  EXPECT_THROW(OcpDerivatives{problem}, ConfigError);
}

TEST(OcpDerivatives, GradientsOnTwoThreadsMatchOneThreadBitForBit) {
  // Each OcpDerivatives linearises on scratch of its own (the model's Jets included), so two may
  // run at once. Checked that it can fail: with the model's shared Jet scratch, both threads
  // counted mismatches.
  testing::SwerveTestProblem scene(testing::SwerveScene::kTurn);
  const OcpProblem& problem = scene.problem;
  const PredictionModel& model = problem.model();
  constexpr int kPlans = 8;
  std::vector<Eigen::MatrixXd> plans;
  for (int p = 0; p < kPlans; ++p) {
    plans.push_back(scene.jittered_inputs(0.1, 9u + static_cast<unsigned>(p)));
    problem.project(plans.back());
  }
  Eigen::MatrixXd states(model.state_size(), problem.horizon() + 1);
  std::vector<double> expected_cost(kPlans);
  std::vector<Eigen::MatrixXd> expected_gradient(kPlans, Eigen::MatrixXd(3, problem.horizon()));
  {
    OcpDerivatives derivatives(problem);
    for (int p = 0; p < kPlans; ++p) {
      const auto index = static_cast<std::size_t>(p);
      expected_cost[index] = derivatives.cost_and_gradient(problem, plans[index], states, expected_gradient[index]);
      ASSERT_TRUE(std::isfinite(expected_cost[index]));
    }
  }
  const auto mismatches = testing::mismatches_on_two_threads(
      kPlans, 3, [&] { return OcpDerivatives(problem); },
      [&](OcpDerivatives& derivatives, int p) {
        const auto index = static_cast<std::size_t>(p);
        Eigen::MatrixXd own_states(model.state_size(), problem.horizon() + 1), gradient(3, problem.horizon());
        const double cost = derivatives.cost_and_gradient(problem, plans[index], own_states, gradient);
        return cost == expected_cost[index] && gradient == expected_gradient[index];
      });
  EXPECT_EQ(mismatches[0], 0);
  EXPECT_EQ(mismatches[1], 0);
}

// The gradient of a plan whose rollout is known, in two parts: its stages linearised in shares,
// here one share on each of two threads (each on scratch of its own, writing disjoint stages), then
// the adjoint recursion. It is the gradient cost_and_gradient gives, to rounding (the shares
// linearise at the double rollout's states, cost_and_gradient at its Jets' own), and the same bit
// for bit as the shares linearised on one thread.
TEST(OcpDerivatives, AKnownRolloutsStagesLinearisedInSharesOnTwoThreadsGiveTheGradient) {
  testing::SwerveTestProblem scene(testing::SwerveScene::kTurn);
  const OcpProblem& problem = scene.problem;
  const int nx = problem.state_size(), horizon = problem.horizon();
  Eigen::MatrixXd plan = scene.jittered_inputs(0.1, 21u);
  problem.project(plan);
  OcpDerivatives reference(problem);
  Eigen::MatrixXd reference_states(nx, horizon + 1), reference_gradient(3, horizon);
  const double reference_cost = reference.cost_and_gradient(problem, plan, reference_states, reference_gradient);
  ASSERT_TRUE(std::isfinite(reference_cost));

  Eigen::MatrixXd states(nx, horizon + 1);
  Eigen::VectorXd stage_costs(horizon), stage_wear(horizon);
  ASSERT_TRUE(std::isfinite(testing::rollout_once(problem, plan, 0, states, stage_costs, stage_wear.data())));
  const int half = horizon / 2;
  Eigen::MatrixXd one_thread_gradient(3, horizon), two_thread_gradient(3, horizon);
  double one_thread_cost = 0.0, two_thread_cost = 0.0;
  {
    OcpDerivatives derivatives(problem);
    const std::unique_ptr<PredictionData> data = problem.model().create_data();
    Eigen::VectorXd x_next(nx);
    ASSERT_EQ(derivatives.linearize_stages(problem, plan, states, 0, half, *data, x_next), half);
    ASSERT_EQ(derivatives.linearize_stages(problem, plan, states, half, horizon, *data, x_next), horizon - half);
    one_thread_cost = derivatives.gradient_of_stages(problem, plan, states, one_thread_gradient);
  }
  {
    OcpDerivatives derivatives(problem);
    const std::unique_ptr<PredictionData> data = problem.model().create_data();
    const std::unique_ptr<PredictionData> worker_data = problem.model().create_data();
    Eigen::VectorXd x_next(nx), worker_x_next(nx);
    int worker_done = 0;
    std::thread worker([&] {
      worker_done = derivatives.linearize_stages(problem, plan, states, half, horizon, *worker_data, worker_x_next);
    });
    const int done = derivatives.linearize_stages(problem, plan, states, 0, half, *data, x_next);
    worker.join();
    ASSERT_EQ(done, half);
    ASSERT_EQ(worker_done, horizon - half);
    two_thread_cost = derivatives.gradient_of_stages(problem, plan, states, two_thread_gradient);
  }
  EXPECT_EQ(two_thread_cost, one_thread_cost);
  EXPECT_EQ(two_thread_gradient, one_thread_gradient);
  EXPECT_NEAR(one_thread_cost, reference_cost, 1e-9 * std::abs(reference_cost));
  const double scale = reference_gradient.cwiseAbs().maxCoeff();
  EXPECT_LT((one_thread_gradient - reference_gradient).cwiseAbs().maxCoeff(), 1e-7 * scale);
}

// A share reports the stages it linearised, and -1 when the model fails on one of them.
TEST(OcpDerivatives, ASharesLinearisationReportsItsStagesAndTheModelsFailure) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 10);
  OcpDerivatives derivatives(problem);
  Eigen::MatrixXd plan = Eigen::MatrixXd::Zero(3, 10), states(6, 11);
  Eigen::VectorXd stage_costs(10), stage_wear(10), x_next(6);
  const std::unique_ptr<PredictionData> data = model.create_data();
  ASSERT_TRUE(std::isfinite(testing::rollout_once(problem, plan, 0, states, stage_costs, stage_wear.data())));
  EXPECT_EQ(derivatives.linearize_stages(problem, plan, states, 2, 7, *data, x_next), 5);
  states(3, 4) = std::numeric_limits<double>::quiet_NaN();  // stage 4 starts from a NaN state
  EXPECT_EQ(derivatives.linearize_stages(problem, plan, states, 2, 7, *data, x_next), -1);
}

}  // namespace
}  // namespace swerve
