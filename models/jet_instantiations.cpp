// Every ceres::Jet instantiation of the models lives in this one translation unit (its compile time
// is the whole build-time cost of automatic differentiation), plus DynamicsJacobian, its user.
#include "swerve/models/jet.hpp"

#include <algorithm>

#include "integrators_impl.hpp"
#include "magic_formula_tire_impl.hpp"
#include "swerve/models/dynamics_jacobian.hpp"
#include "vehicle_model_impl.hpp"

namespace swerve {

template WheelSlip<ModelJet> compute_wheel_slip<ModelJet>(const MagicFormulaParams&, ModelJet, ModelJet, ModelJet);
template class MagicFormulaTire<ModelJet>;
template class VehicleModel<ModelJet>;
template class DiscreteDynamics<ModelJet>;

struct DynamicsJacobian::Impl {
  Impl(const VehicleParams& params, Fidelity fidelity, IntegratorMethod method)
      : model(params, fidelity),
        dynamics(model, method),
        nx(model.state_size()),
        nu(model.input_size()),
        x(nx),
        u(nu),
        out(nx) {}

  // Seeds directions [start, start + kModelJetSize) of the stacked (x, u) with unit vectors.
  void seed(const Eigen::Ref<const Eigen::VectorXd>& x_value, const Eigen::Ref<const Eigen::VectorXd>& u_value,
            int start) {
    for (int k = 0; k < nx; ++k) {
      x[k] = ModelJet(x_value[k]);
      const int d = k - start;
      if (d >= 0 && d < kModelJetSize) x[k].v[d] = 1.0;
    }
    for (int k = 0; k < nu; ++k) {
      u[k] = ModelJet(u_value[k]);
      const int d = nx + k - start;
      if (d >= 0 && d < kModelJetSize) u[k].v[d] = 1.0;
    }
  }

  // Copies the derivative parts of `out` (and of `scalar`) for the chunk starting at `start`.
  void scatter(int start, Eigen::Ref<Eigen::MatrixXd>& a, Eigen::Ref<Eigen::MatrixXd>& b,
               const ModelJet& scalar, double* gradient) const {
    const int end = std::min(start + kModelJetSize, nx + nu);
    for (int column = start; column < end; ++column) {
      const int d = column - start;
      if (column < nx) {
        for (int row = 0; row < nx; ++row) a(row, column) = out[row].v[d];
      } else {
        for (int row = 0; row < nx; ++row) b(row, column - nx) = out[row].v[d];
      }
      if (gradient != nullptr) gradient[column] = scalar.v[d];
    }
  }

  template <typename Evaluate>
  ModelStatus run(const Eigen::Ref<const Eigen::VectorXd>& x_value, const Eigen::Ref<const Eigen::VectorXd>& u_value,
                  Eigen::Ref<Eigen::VectorXd>& value, Eigen::Ref<Eigen::MatrixXd>& a,
                  Eigen::Ref<Eigen::MatrixXd>& b, double* scalar_value, double* gradient, Evaluate evaluate) {
    if (x_value.size() != nx || u_value.size() != nu || value.size() != nx || a.rows() != nx ||
        a.cols() != nx || b.rows() != nx || b.cols() != nu) {
      return ModelStatus::kInvalidArgument;
    }
    ModelJet scalar;
    for (int start = 0; start < nx + nu; start += kModelJetSize) {
      seed(x_value, u_value, start);
      const ModelStatus status = evaluate(&scalar);
      if (status != ModelStatus::kOk) {
        value.setConstant(detail::kQuietNaN);
        a.setConstant(detail::kQuietNaN);
        b.setConstant(detail::kQuietNaN);
        return status;
      }
      scatter(start, a, b, scalar, gradient);
    }
    for (int row = 0; row < nx; ++row) value[row] = out[row].a;
    if (scalar_value != nullptr) *scalar_value = scalar.a;
    return ModelStatus::kOk;
  }

  VehicleModel<ModelJet> model;
  DiscreteDynamics<ModelJet> dynamics;
  int nx;
  int nu;
  VehicleModel<ModelJet>::Vector x, u, out;
};

DynamicsJacobian::DynamicsJacobian(const VehicleParams& params, Fidelity fidelity, IntegratorMethod method)
    : impl_(std::make_unique<Impl>(params, fidelity, method)) {}
DynamicsJacobian::~DynamicsJacobian() = default;
DynamicsJacobian::DynamicsJacobian(DynamicsJacobian&&) noexcept = default;
DynamicsJacobian& DynamicsJacobian::operator=(DynamicsJacobian&&) noexcept = default;

int DynamicsJacobian::state_size() const { return impl_->nx; }
int DynamicsJacobian::input_size() const { return impl_->nu; }

ModelStatus DynamicsJacobian::discrete(const Eigen::Ref<const Eigen::VectorXd>& x,
                                       const Eigen::Ref<const Eigen::VectorXd>& u, double dt, int substeps,
                                       Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                       Eigen::Ref<Eigen::MatrixXd> b, double* wear, double* wear_gradient) noexcept {
  Impl& impl = *impl_;
  return impl.run(x, u, x_next, a, b, wear, wear_gradient, [&](ModelJet* stage_wear) {
    return impl.dynamics.step(impl.x, impl.u, dt, substeps, impl.out, stage_wear);
  });
}

ModelStatus DynamicsJacobian::continuous(const Eigen::Ref<const Eigen::VectorXd>& x,
                                         const Eigen::Ref<const Eigen::VectorXd>& u,
                                         Eigen::Ref<Eigen::VectorXd> x_dot, Eigen::Ref<Eigen::MatrixXd> a,
                                         Eigen::Ref<Eigen::MatrixXd> b, double* wear_rate,
                                         double* wear_rate_gradient) noexcept {
  Impl& impl = *impl_;
  return impl.run(x, u, x_dot, a, b, wear_rate, wear_rate_gradient, [&](ModelJet* rate) {
    return impl.model.derivative(impl.x, impl.u, impl.out, nullptr, rate);
  });
}

}  // namespace swerve
