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

  // The integrator's scratch (stage derivatives, per-module diagnostics), owned by its caller:
  // one per thread makes steps re-entrant. Sized once, so step() on it allocates nothing.
  struct Data {
    explicit Data(const DiscreteDynamics& dynamics)
        : k1(dynamics.model().state_size()), k2(k1.size()), k3(k1.size()), k4(k1.size()), stage(k1.size()),
          current(k1.size()), diagnostics(static_cast<std::size_t>(dynamics.model().modules())),
          module_wear(static_cast<std::size_t>(dynamics.model().modules()), T(0.0)) {}
    Vector k1, k2, k3, k4, stage, current;
    std::vector<ModuleDiagnostics<T>> diagnostics;
    std::vector<T> module_wear;
  };

  // Keeps a reference to `model`, which must outlive this object. Holds no scratch: steps on
  // separate Data may run on separate threads.
  explicit DiscreteDynamics(const VehicleModel<T>& model, IntegratorMethod method = IntegratorMethod::kRk4);

  const VehicleModel<T>& model() const { return model_; }
  IntegratorMethod method() const { return method_; }
  Data create_data() const { return Data(*this); }

  // x_next = F(x, u, dt) with `substeps` equal substeps h = dt / substeps. If given, `wear` receives
  // the total wear of all modules over the step, the integral of sum_i w_dot_i computed by the same
  // rule as the state (RK4: h/6 (w1 + 2 w2 + 2 w3 + w4) per substep, i.e. RK4 on the state augmented
  // by W), and `module_wear` (array of modules() entries) the per-module integrals. x_next may not
  // alias x. Returns a non-kOk status (x_next NaN) for non-finite x or u, dt <= 0 or substeps < 1.
  // No allocation.
  ModelStatus step(Data& data, const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u, double dt,
                   int substeps, Eigen::Ref<Vector> x_next, T* wear = nullptr, T* module_wear = nullptr) const noexcept;
  // The same on scratch made for this call: for code off the real-time path (it allocates).
  ModelStatus step(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u, double dt, int substeps,
                   Eigen::Ref<Vector> x_next, T* wear = nullptr, T* module_wear = nullptr) const {
    Data data(*this);
    return step(data, x, u, dt, substeps, x_next, wear, module_wear);
  }

 private:
  const VehicleModel<T>& model_;
  IntegratorMethod method_;
};

}  // namespace swerve
