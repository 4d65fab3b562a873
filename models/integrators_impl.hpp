// Template definitions of DiscreteDynamics, included by the .cpp files that instantiate it.
#pragma once

#include "scalar_utils.hpp"
#include "swerve/models/integrators.hpp"

namespace swerve {

template <typename T>
DiscreteDynamics<T>::DiscreteDynamics(const VehicleModel<T>& model, IntegratorMethod method)
    : model_(model), method_(method) {}

template <typename T>
ModelStatus DiscreteDynamics<T>::step(Data& data, const Eigen::Ref<const Vector>& x,
                                      const Eigen::Ref<const Vector>& u, double dt, int substeps,
                                      Eigen::Ref<Vector> x_next, T* wear, T* module_wear) const noexcept {
  const int nx = model_.state_size();
  const int n = model_.modules();
  if (x.size() != nx || x_next.size() != nx || u.size() != model_.input_size() || !(dt > 0.0) ||
      !std::isfinite(dt) || substeps < 1 || data.current.size() != nx ||
      data.diagnostics.size() != static_cast<std::size_t>(n)) {
    return ModelStatus::kInvalidArgument;
  }
  const double h = dt / substeps;
  const bool want_modules = module_wear != nullptr;
  ModuleDiagnostics<T>* diag = want_modules ? data.diagnostics.data() : nullptr;
  T total{0.0};
  T rate{0.0};
  if (want_modules) {
    for (auto& w : data.module_wear) w = T(0.0);
  }
  // Adds weight * (stage wear rates) to the running integrals.
  auto accumulate = [&](double weight) {
    total += weight * rate;
    if (want_modules) {
      for (int i = 0; i < n; ++i) {
        const auto k = static_cast<std::size_t>(i);
        data.module_wear[k] += weight * data.diagnostics[k].wear_rate;
      }
    }
  };
  auto fail = [&](ModelStatus status) {
    x_next.setConstant(T(detail::kQuietNaN));
    return status;
  };

  data.current = x;
  for (int sub = 0; sub < substeps; ++sub) {
    ModelStatus status = model_.derivative(data.current, u, data.k1, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    if (method_ == IntegratorMethod::kEuler) {
      accumulate(h);
      data.current += h * data.k1;
      continue;
    }
    accumulate(h / 6.0);
    data.stage = data.current + (0.5 * h) * data.k1;
    status = model_.derivative(data.stage, u, data.k2, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 3.0);
    data.stage = data.current + (0.5 * h) * data.k2;
    status = model_.derivative(data.stage, u, data.k3, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 3.0);
    data.stage = data.current + h * data.k3;
    status = model_.derivative(data.stage, u, data.k4, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 6.0);
    data.current += (h / 6.0) * (data.k1 + 2.0 * data.k2 + 2.0 * data.k3 + data.k4);
  }
  x_next = data.current;
  if (wear != nullptr) *wear = total;
  if (want_modules) {
    for (int i = 0; i < n; ++i) module_wear[i] = data.module_wear[static_cast<std::size_t>(i)];
  }
  return ModelStatus::kOk;
}

}  // namespace swerve
