// The discrete map x_{k+1} = F(x_k, u_k, dt) of a VehicleModel (explicit Euler or classic RK4 with
// substeps, u held constant over the step) that every solver and the simulator share. It also
// integrates the tire wear over the step with the same quadrature, so a stage cost can use it.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "swerve/models/vehicle_model.hpp"

namespace swerve {

enum class IntegratorMethod { kEuler, kRk4 };
const char* to_string(IntegratorMethod method);  // "euler", "rk4"

template <typename T>
class DiscreteDynamics {
 public:
  using Vector = typename VehicleModel<T>::Vector;

  // Keeps a reference to `model` (which must outlive this object) and preallocates the stage
  // buffers. step() uses them, so one instance serves one thread at a time.
  explicit DiscreteDynamics(const VehicleModel<T>& model, IntegratorMethod method = IntegratorMethod::kRk4);

  const VehicleModel<T>& model() const { return model_; }
  IntegratorMethod method() const { return method_; }

  // x_next = F(x, u, dt) with `substeps` equal substeps h = dt / substeps. If given, `wear` receives
  // the total wear of all modules over the step, the integral of sum_i w_dot_i computed by the same
  // rule as the state (RK4: h/6 (w1 + 2 w2 + 2 w3 + w4) per substep, i.e. RK4 on the state augmented
  // by W), and `module_wear` (array of modules() entries) the per-module integrals. x_next may not
  // alias x. Returns a non-kOk status (x_next NaN) for non-finite x or u, dt <= 0 or substeps < 1.
  ModelStatus step(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u, double dt,
                   int substeps, Eigen::Ref<Vector> x_next, T* wear = nullptr,
                   T* module_wear = nullptr) const noexcept;

 private:
  const VehicleModel<T>& model_;
  IntegratorMethod method_;
  mutable Vector k1_, k2_, k3_, k4_, stage_, current_;
  mutable std::vector<ModuleDiagnostics<T>> diagnostics_;
  mutable std::vector<T> module_wear_;
};

}  // namespace swerve
