#include "swerve/ocp/vehicle_prediction_model.hpp"

#include <cmath>
#include <sstream>
#include <utility>

#include "prediction_step.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {

const char* to_string(PredictionMethod method) noexcept {
  return method == PredictionMethod::kSemiImplicit ? "semi_implicit" : "rk4";
}

void PredictionOptions::validate() const {
  auto reject = [](const char* field, int value, const char* rule) {
    std::ostringstream message;
    message << "PredictionOptions." << field << " = " << value << ": " << rule;
    throw ConfigError(message.str());
  };
  if (substeps < 1) reject("substeps", substeps, "must be >= 1");
  if (slow_substeps < 1) reject("slow_substeps", slow_substeps, "must be >= 1");
  if (max_newton_iterations < 1) reject("max_newton_iterations", max_newton_iterations, "must be >= 1");
}

const VehicleModel<double>& VehiclePredictionModel::vehicle() const noexcept { return values_->model(); }

VehiclePredictionModel::Data::Data(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VehiclePredictionModel::Data::Data(Data&&) noexcept = default;
VehiclePredictionModel::Data& VehiclePredictionModel::Data::operator=(Data&&) noexcept = default;
VehiclePredictionModel::Data::~Data() = default;

VehiclePredictionModel::Data VehiclePredictionModel::create_data() const {
  return Data(std::make_unique<Data::Impl>(*values_));
}

long VehiclePredictionModel::model_evaluations() const noexcept { return model_evaluations(*data_); }

long VehiclePredictionModel::model_evaluations(const Data& data) noexcept {
  return detail::PredictionStep<double>::model_evaluations(data.impl_->values);
}

bool VehiclePredictionModel::step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                                  double dt, Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  return step(*data_, x, u, dt, x_next, stage_wear);
}

bool VehiclePredictionModel::step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                  Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  if (x.size() != state_size_ || u.size() != input_size_ || x_next.size() != state_size_ || !(dt > 0.0) ||
      !std::isfinite(dt) || !x.allFinite() || !u.allFinite()) {
    return false;
  }
  return values_->step(data.impl_->values, x, u, dt, x_next, stage_wear);
}

void VehiclePredictionModel::module_inputs(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body,
                                           double dt, Eigen::Ref<Eigen::VectorXd> inputs) const noexcept {
  values_->module_inputs(x, twist_body, dt, inputs);
}

bool VehiclePredictionModel::twist_step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body,
                                        double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                                        double* stage_wear) const noexcept {
  return twist_step(*data_, x, twist_body, dt, x_next, stage_wear);
}

bool VehiclePredictionModel::twist_step(Data& data, const Eigen::Ref<const Eigen::VectorXd>& x,
                                        const Eigen::Vector3d& twist_body, double dt, Eigen::Ref<Eigen::VectorXd> x_next,
                                        double* stage_wear) const noexcept {
  if (x.size() != state_size_ || x_next.size() != state_size_ || !(dt > 0.0) || !std::isfinite(dt) ||
      !x.allFinite() || !twist_body.allFinite()) {
    return false;
  }
  Data::Impl& scratch = *data.impl_;
  values_->module_inputs(x, twist_body, dt, scratch.inputs);
  return values_->step(scratch.values, x, scratch.inputs, dt, x_next, stage_wear);
}

}  // namespace swerve
