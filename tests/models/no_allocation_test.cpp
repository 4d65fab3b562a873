// After construction the models allocate nothing: derivative (ideal and plant), the RK4 step with
// its wear outputs, and the Jet Jacobians of f and F (counted by hooking malloc, not timed).
#include <gtest/gtest.h>

#include "support/model_fixtures.hpp"
#include "support/allocation_counter.hpp"
#include "swerve/models/dynamics_jacobian.hpp"
#include "swerve/models/integrators.hpp"

namespace swerve {
namespace {

using Vector = Eigen::VectorXd;

TEST(ModelsAllocation, DerivativeStepAndJacobiansAllocateNothing) {
  if (!swerve::testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting unavailable (a sanitizer owns malloc)";
  for (int n : {4, 16}) {
    for (Fidelity fidelity : {Fidelity::kIdeal, Fidelity::kPlant}) {
      VehicleParams params = swerve::testing::make_params(n);
      params.cog_height = 0.3;
      params.plant.load_transfer = true;
      params.plant.relaxation_length = 0.1;
      const VehicleModel<double> model(params, fidelity);
      const DiscreteDynamics<double> dynamics(model);
      DiscreteDynamics<double>::Data dynamics_data = dynamics.create_data();
      DynamicsJacobian jacobian(params, fidelity);
      const int nx = model.state_size();
      const int nu = model.input_size();
      Vector x = Vector::Constant(nx, 0.2);
      const Vector u = Vector::Constant(nu, 3.0);
      Vector x_dot(nx);
      Vector next(nx);
      Eigen::MatrixXd a(nx, nx);
      Eigen::MatrixXd b(nx, nu);
      Vector gradient(nx + nu);
      std::vector<ModuleDiagnostics<double>> diag(static_cast<std::size_t>(n));
      std::vector<double> module_wear(static_cast<std::size_t>(n));
      double wear = 0.0;
      swerve::testing::AllocationCounter counter;
      EXPECT_EQ(model.derivative(x, u, x_dot, diag.data(), &wear), ModelStatus::kOk);
      EXPECT_EQ(dynamics.step(dynamics_data, x, u, 0.05, 2, next, &wear, module_wear.data()), ModelStatus::kOk);
      EXPECT_EQ(jacobian.discrete(x, u, 0.05, 2, next, a, b, &wear, gradient.data()), ModelStatus::kOk);
      EXPECT_EQ(jacobian.continuous(x, u, x_dot, a, b, &wear, gradient.data()), ModelStatus::kOk);
      // Fixed-size blocks of preallocated storage are fine too (how solvers pass their stages).
      EXPECT_EQ(dynamics.step(dynamics_data, x.head(nx), u, 0.05, 1, next.head(nx)), ModelStatus::kOk);
      EXPECT_EQ(counter.count(), 0) << n << " modules, fidelity " << static_cast<int>(fidelity);
    }
  }
}

}  // namespace
}  // namespace swerve
