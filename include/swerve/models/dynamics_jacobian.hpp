// Exact Jacobians of the continuous dynamics f(x, u) and of the discrete map F(x, u, dt) (and of
// its stage wear) by forward-mode automatic differentiation: ceres::Jet<double, 8> evaluated in
// chunks of 8 directions over the nx + nu inputs. The Jets stay inside models/; this API is double.
// These are the plant model's maps (RK4, any fidelity), for linearising the vehicle itself; the
// optimisers' prediction step has its own, semi_implicit_step_jacobian.hpp, on the same chunks.
#pragma once

#include <Eigen/Core>

#include <memory>

#include "swerve/models/integrators.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

class DynamicsJacobian {
 public:
  // Builds its own Jet-valued model and integrator from `params` (validated; throws ConfigError).
  DynamicsJacobian(const VehicleParams& params, Fidelity fidelity,
                   IntegratorMethod method = IntegratorMethod::kRk4);
  ~DynamicsJacobian();
  DynamicsJacobian(DynamicsJacobian&&) noexcept;
  DynamicsJacobian& operator=(DynamicsJacobian&&) noexcept;

  int state_size() const;
  int input_size() const;

  // x_next = F(x, u, dt) (substeps as DiscreteDynamics::step), a = dF/dx (nx x nx),
  // b = dF/du (nx x nu). If `wear` is given it receives the stage wear W(x, u) of
  // DiscreteDynamics::step, and if `wear_gradient` is given (nx + nu entries) its gradient
  // [dW/dx, dW/du]. No allocation; one instance serves one thread at a time.
  ModelStatus discrete(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                       double dt, int substeps, Eigen::Ref<Eigen::VectorXd> x_next,
                       Eigen::Ref<Eigen::MatrixXd> a, Eigen::Ref<Eigen::MatrixXd> b,
                       double* wear = nullptr, double* wear_gradient = nullptr) noexcept;

  // x_dot = f(x, u), a = df/dx, b = df/du, optionally the total wear rate and its gradient.
  ModelStatus continuous(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                         Eigen::Ref<Eigen::VectorXd> x_dot, Eigen::Ref<Eigen::MatrixXd> a,
                         Eigen::Ref<Eigen::MatrixXd> b, double* wear_rate = nullptr,
                         double* wear_rate_gradient = nullptr) noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace swerve
