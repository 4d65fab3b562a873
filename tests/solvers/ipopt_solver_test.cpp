// What only the Ipopt backend promises beyond the shared conformance suite (which checks its
// convergence, defects, warm start and deadline with every other backend): the inputs of the LQ
// optimum themselves, and bad options named by their field.
#include "swerve/solvers/ipopt_solver.hpp"

#include <gtest/gtest.h>

#include "support/linear_models.hpp"
#include "support/swerve_problems.hpp"
#include "swerve/config/config_error.hpp"

namespace swerve {
namespace {

using namespace std::chrono_literals;

IpoptOptions tight() {
  IpoptOptions options;
  options.tol = 1e-8;
  options.max_iterations = 3000;
  return options;
}

TEST(IpoptSolver, ReachesTheLinearQuadraticOptimumToOneMicroRelative) {
  const testing::DoubleIntegratorModel model(0.5);
  const OcpProblem problem = testing::make_lq_problem(model, 8);
  const Eigen::MatrixXd optimum = testing::double_integrator_optimum(problem, model);
  Eigen::MatrixXd states(6, 9);
  const double optimal_cost = problem.evaluate(optimum, states).total();
  IpoptSolver solver(problem, tight());
  Solution solution;
  solution.resize(6, 3, 8);
  SolveSummary summary;
  ASSERT_EQ(solver.solve(problem, {}, SolverClock::now() + 10s, &solution, &summary), SolveStatus::kConverged);
  EXPECT_NEAR(solution.cost, optimal_cost, 1e-6 * optimal_cost);
  EXPECT_LT((solution.inputs - optimum).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(IpoptSolver, RejectsBadOptionsNamingTheField) {
  testing::SwerveTestProblem s(testing::SwerveScene::kSidestep);
  auto expect_rejected = [&](IpoptOptions options, const std::string& field) {
    try {
      IpoptSolver solver(s.problem, options);
      FAIL() << field << " accepted";
    } catch (const ConfigError& error) {
      EXPECT_NE(std::string(error.what()).find("IpoptOptions." + field), std::string::npos) << error.what();
    }
  };
  IpoptOptions options;
  options.tol = -1.0;
  expect_rejected(options, "tol");
  options = IpoptOptions{};
  options.mu_strategy = "probing";
  expect_rejected(options, "mu_strategy");
  options = IpoptOptions{};
  options.linear_solver = "ma57";
  expect_rejected(options, "linear_solver");
  options = IpoptOptions{};
  options.max_iterations = 0;
  expect_rejected(options, "max_iterations");
}

}  // namespace
}  // namespace swerve
