// Every ceres::Jet instantiation of the models lives in this one translation unit (its compile time
// is the whole build-time cost of automatic differentiation), plus DynamicsJacobian, its user.
#include "swerve/models/jet.hpp"
#include "swerve/models/jet_chunks.hpp"

#include "integrators_impl.hpp"
#include "magic_formula_tire_impl.hpp"
#include "swerve/models/dynamics_jacobian.hpp"
#include "vehicle_model_impl.hpp"

namespace swerve {

template WheelSlip<ModelJet> compute_wheel_slip<ModelJet>(const MagicFormulaParams&, ModelJet, ModelJet, ModelJet);
template class MagicFormulaTire<ModelJet>;
template class VehicleModel<ModelJet>;
template class DiscreteDynamics<ModelJet>;
template WheelSlip<TwistJet> compute_wheel_slip<TwistJet>(const MagicFormulaParams&, TwistJet, TwistJet, TwistJet);
template class MagicFormulaTire<TwistJet>;
template class VehicleModel<TwistJet>;
template WheelSlip<ModuleJet> compute_wheel_slip<ModuleJet>(const MagicFormulaParams&, ModuleJet, ModuleJet, ModuleJet);
template class MagicFormulaTire<ModuleJet>;
template class VehicleModel<ModuleJet>;

struct DynamicsJacobian::Impl {
  Impl(const VehicleParams& params, Fidelity fidelity, IntegratorMethod method)
      : model(params, fidelity),
        dynamics(model, method),
        dynamics_data(dynamics),
        nx(model.state_size()),
        nu(model.input_size()),
        x(nx),
        u(nu),
        out(nx) {}

  template <typename Evaluate>
  ModelStatus run(const Eigen::Ref<const Eigen::VectorXd>& x_value, const Eigen::Ref<const Eigen::VectorXd>& u_value,
                  Eigen::Ref<Eigen::VectorXd>& value, Eigen::Ref<Eigen::MatrixXd>& a,
                  Eigen::Ref<Eigen::MatrixXd>& b, double* scalar_value, double* gradient, Evaluate evaluate) {
    if (x_value.size() != nx || u_value.size() != nu || value.size() != nx || a.rows() != nx ||
        a.cols() != nx || b.rows() != nx || b.cols() != nu) {
      return ModelStatus::kInvalidArgument;
    }
    ModelStatus status = ModelStatus::kOk;
    jet_jacobian(x_value, u_value, x, u, out, value, a, b, scalar_value, gradient, [&](ModelJet* scalar) {
      status = evaluate(scalar);
      return status == ModelStatus::kOk;
    });
    return status;
  }

  VehicleModel<ModelJet> model;
  DiscreteDynamics<ModelJet> dynamics;
  DiscreteDynamics<ModelJet>::Data dynamics_data;
  int nx;
  int nu;
  ModelJetVector x, u, out;
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
    return impl.dynamics.step(impl.dynamics_data, impl.x, impl.u, dt, substeps, impl.out, stage_wear);
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
