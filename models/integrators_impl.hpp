// Template definitions of DiscreteDynamics, included by the .cpp files that instantiate it.
#pragma once

#include "scalar_utils.hpp"
#include "swerve/models/integrators.hpp"

namespace swerve {

template <typename T>
DiscreteDynamics<T>::DiscreteDynamics(const VehicleModel<T>& model, IntegratorMethod method)
    : model_(model),
      method_(method),
      k1_(model.state_size()),
      k2_(model.state_size()),
      k3_(model.state_size()),
      k4_(model.state_size()),
      stage_(model.state_size()),
      current_(model.state_size()),
      diagnostics_(static_cast<std::size_t>(model.modules())),
      module_wear_(static_cast<std::size_t>(model.modules()), T(0.0)) {}

template <typename T>
ModelStatus DiscreteDynamics<T>::step(const Eigen::Ref<const Vector>& x, const Eigen::Ref<const Vector>& u,
                                      double dt, int substeps, Eigen::Ref<Vector> x_next, T* wear,
                                      T* module_wear) const noexcept {
  const int nx = model_.state_size();
  const int n = model_.modules();
  if (x.size() != nx || x_next.size() != nx || u.size() != model_.input_size() || !(dt > 0.0) ||
      !std::isfinite(dt) || substeps < 1) {
    return ModelStatus::kInvalidArgument;
  }
  const double h = dt / substeps;
  const bool want_modules = module_wear != nullptr;
  ModuleDiagnostics<T>* diag = want_modules ? diagnostics_.data() : nullptr;
  T total{0.0};
  T rate{0.0};
  if (want_modules) {
    for (auto& w : module_wear_) w = T(0.0);
  }
  // Adds weight * (stage wear rates) to the running integrals.
  auto accumulate = [&](double weight) {
    total += weight * rate;
    if (want_modules) {
      for (int i = 0; i < n; ++i) {
        module_wear_[static_cast<std::size_t>(i)] += weight * diagnostics_[static_cast<std::size_t>(i)].wear_rate;
      }
    }
  };
  auto fail = [&](ModelStatus status) {
    x_next.setConstant(T(detail::kQuietNaN));
    return status;
  };

  current_ = x;
  for (int sub = 0; sub < substeps; ++sub) {
    ModelStatus status = model_.derivative(current_, u, k1_, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    if (method_ == IntegratorMethod::kEuler) {
      accumulate(h);
      current_ += h * k1_;
      continue;
    }
    accumulate(h / 6.0);
    stage_ = current_ + (0.5 * h) * k1_;
    status = model_.derivative(stage_, u, k2_, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 3.0);
    stage_ = current_ + (0.5 * h) * k2_;
    status = model_.derivative(stage_, u, k3_, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 3.0);
    stage_ = current_ + h * k3_;
    status = model_.derivative(stage_, u, k4_, diag, &rate);
    if (status != ModelStatus::kOk) return fail(status);
    accumulate(h / 6.0);
    current_ += (h / 6.0) * (k1_ + 2.0 * k2_ + 2.0 * k3_ + k4_);
  }
  x_next = current_;
  if (wear != nullptr) *wear = total;
  if (want_modules) {
    for (int i = 0; i < n; ++i) module_wear[i] = module_wear_[static_cast<std::size_t>(i)];
  }
  return ModelStatus::kOk;
}

}  // namespace swerve
