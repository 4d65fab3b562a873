#include "swerve/ocp/vehicle_prediction_model.hpp"

#include <cmath>
#include <utility>

#include "swerve/core/dcheck.hpp"
#include "swerve/models/semi_implicit_step.hpp"
#include "vehicle_prediction_data.hpp"

namespace swerve {

VehiclePredictionModel::VehiclePredictionModel(const VehicleParams& params, PredictionOptions options)
    : options_(options) {
  options_.validate();
  values_ = std::make_unique<SemiImplicitStep<double>>(params, options_);
  jacobian_ = std::make_unique<SemiImplicitStepJacobian>(params, options_);
  modules_ = values_->model().modules();
  state_size_ = values_->state_size();
  input_size_ = values_->model().input_size();
  module_jacobian_chunks_ = SemiImplicitStepJacobian::chunks(state_size_ + input_size_);
  twist_jacobian_chunks_ = SemiImplicitStepJacobian::chunks(state_size_ + 3);
}

void VehiclePredictionModel::observe_friction_scales(const double* scales) noexcept {
  values_->observe_friction_scales(scales);
  jacobian_->observe_friction_scales(scales);
}

void VehiclePredictionModel::observe_wear_weights(const double* weights) noexcept {
  values_->observe_wear_weights(weights);
  jacobian_->observe_wear_weights(weights);
}

void VehiclePredictionModel::observe_module_faults(const ModuleFaults* faults) noexcept {
  values_->observe_module_faults(faults);
  jacobian_->observe_module_faults(faults);
}

double VehiclePredictionModel::module_evaluations_per_linearisation() noexcept { return 1.4; }
double VehiclePredictionModel::module_evaluations_per_jet_chunk() noexcept { return 1.0; }

template <typename Evaluate>
bool VehiclePredictionModel::charged_jacobian(Data::Impl& own, int chunks, const Evaluate& evaluate) const noexcept {
  const long evaluations = SemiImplicitStepJacobian::model_evaluations(own.jacobian);
  const long linearisations = SemiImplicitStepJacobian::linearisations(own.jacobian);
  const bool ok = evaluate();
  if (work_clock_ != nullptr) {
    const double made = static_cast<double>(SemiImplicitStepJacobian::model_evaluations(own.jacobian) - evaluations);
    const double linearised =
        static_cast<double>(SemiImplicitStepJacobian::linearisations(own.jacobian) - linearisations);
    work_clock_->charge(static_cast<double>(modules_) * (made + module_evaluations_per_linearisation() * linearised +
                                                         module_evaluations_per_jet_chunk() * chunks));
  }
  return ok;
}

bool VehiclePredictionModel::charged_step(Data::Impl& own, const Eigen::Ref<const Eigen::VectorXd>& x,
                                          const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                          Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  const long before = SemiImplicitStep<double>::model_evaluations(own.values);
  const bool ok = values_->step(own.values, x, u, dt, x_next, stage_wear);
  if (work_clock_ != nullptr) {
    work_clock_->charge(static_cast<double>(modules_) *
                        static_cast<double>(SemiImplicitStep<double>::model_evaluations(own.values) - before));
  }
  return ok;
}

VehiclePredictionModel::~VehiclePredictionModel() = default;

const VehicleModel<double>& VehiclePredictionModel::vehicle() const noexcept { return values_->model(); }

VehiclePredictionModel::Data::Data(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VehiclePredictionModel::Data::Data(Data&&) noexcept = default;
VehiclePredictionModel::Data& VehiclePredictionModel::Data::operator=(Data&&) noexcept = default;
VehiclePredictionModel::Data::~Data() = default;

std::unique_ptr<PredictionData> VehiclePredictionModel::create_data() const {
  return std::unique_ptr<Data>(new Data(std::make_unique<Data::Impl>(*values_, *jacobian_)));
}

VehiclePredictionModel::Data::Impl& VehiclePredictionModel::scratch(PredictionData& data) noexcept {
  SWERVE_DCHECK(dynamic_cast<Data*>(&data) != nullptr);
  return *static_cast<Data&>(data).impl_;
}

int VehiclePredictionModel::wheel_speed_states() const noexcept { return values_->wheel_speed_states(); }
int VehiclePredictionModel::steering_rate_states() const noexcept { return values_->steering_rate_states(); }

long VehiclePredictionModel::model_evaluations(const PredictionData& data) noexcept {
  return SemiImplicitStep<double>::model_evaluations(static_cast<const Data&>(data).impl_->values);
}

bool VehiclePredictionModel::step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                  Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  if (x.size() != state_size_ || u.size() != input_size_ || x_next.size() != state_size_ || !(dt > 0.0) ||
      !std::isfinite(dt) || !x.allFinite() || !u.allFinite()) {
    return false;
  }
  return charged_step(scratch(data), x, u, dt, x_next, stage_wear);
}

void VehiclePredictionModel::module_inputs(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body,
                                           double dt, Eigen::Ref<Eigen::VectorXd> inputs) const noexcept {
  values_->module_inputs(x, twist_body, dt, inputs);
}

bool VehiclePredictionModel::twist_step(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                        const Eigen::Vector3d& twist_body, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                                        double* stage_wear) const noexcept {
  if (x.size() != state_size_ || x_next.size() != state_size_ || !(dt > 0.0) || !std::isfinite(dt) ||
      !x.allFinite() || !twist_body.allFinite()) {
    return false;
  }
  Data::Impl& own = scratch(data);
  values_->module_inputs(x, twist_body, dt, own.inputs);
  return charged_step(own, x, own.inputs, dt, x_next, stage_wear);
}

bool VehiclePredictionModel::step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                            Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                            Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                            Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  Data::Impl& own = scratch(data);
  return charged_jacobian(own, module_jacobian_chunks_, [&] {
    return jacobian_->module_step(own.jacobian, x, u, dt, x_next, a, b, stage_wear, wear_gradient);
  });
}

bool VehiclePredictionModel::twist_step_jacobians(PredictionData& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                                  const Eigen::Vector3d& twist_body, double dt,
                                                  Eigen::Ref<Eigen::VectorXd> x_next, Eigen::Ref<Eigen::MatrixXd> a,
                                                  Eigen::Ref<Eigen::MatrixXd> b, double* stage_wear,
                                                  Eigen::Ref<Eigen::VectorXd> wear_gradient) const noexcept {
  Data::Impl& own = scratch(data);
  return charged_jacobian(own, twist_jacobian_chunks_, [&] {
    return jacobian_->twist_step(own.jacobian, x, twist_body, dt, x_next, a, b, stage_wear, wear_gradient);
  });
}

}  // namespace swerve
