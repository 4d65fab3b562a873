#include "swerve/models/model_linearisation.hpp"

#include <cmath>

namespace swerve {

ModelLinearisation::Data::Data(const ModelLinearisation& linearisation)
    : state(Eigen::Matrix<ModuleJet, Eigen::Dynamic, 1>::Zero(linearisation.model_.state_size())),
      inputs(Eigen::Matrix<ModuleJet, Eigen::Dynamic, 1>::Zero(linearisation.model_.input_size())),
      state_dot(Eigen::Matrix<ModuleJet, Eigen::Dynamic, 1>::Zero(linearisation.model_.state_size())),
      diagnostics(static_cast<std::size_t>(linearisation.model_.modules())) {}

ModelLinearisation::ModelLinearisation(const VehicleParams& params) : model_(params, Fidelity::kIdeal) {
  const int n = model_.modules();
  per_force_x_.resize(3, n);
  per_force_y_.resize(3, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix<double, 3, 2> per_force = model_.acceleration_per_module_force(i);
    per_force_x_.col(i) = per_force.col(0);
    per_force_y_.col(i) = per_force.col(1);
  }
}

ModelLinearisation::Point ModelLinearisation::make_point() const {
  const int n = model_.modules();
  Point point;
  point.acceleration.setZero();
  point.acceleration_per_twist.setZero();
  point.acceleration_per_steering = Eigen::Matrix3Xd::Zero(3, n);
  point.acceleration_per_wheel_speed = Eigen::Matrix3Xd::Zero(3, n);
  point.wear_rate_per_twist.setZero();
  point.wear_rate_per_steering = Eigen::VectorXd::Zero(n);
  point.wear_rate_per_wheel_speed = Eigen::VectorXd::Zero(n);
  point.module_wear_rate = Eigen::VectorXd::Zero(n);
  point.module_wear_rate_per_twist = Eigen::Matrix3Xd::Zero(3, n);
  point.drive_force = Eigen::VectorXd::Zero(n);
  point.drive_force_partials = Eigen::Matrix<double, Eigen::Dynamic, 5>::Zero(n, 5);
  return point;
}

bool ModelLinearisation::linearise(Data& data, const Eigen::Ref<const Eigen::VectorXd>& state,
                                   const Eigen::Ref<const Eigen::VectorXd>& inputs,
                                   Point* point) const noexcept {
  const int n = model_.modules();
  if (state.size() != model_.state_size() || inputs.size() != model_.input_size() ||
      data.state.size() != state.size() || data.inputs.size() != inputs.size() ||
      point->drive_force.size() != n) {
    return false;
  }
  for (Eigen::Index k = 0; k < state.size(); ++k) data.state[k] = ModuleJet(state[k]);
  for (Eigen::Index k = 0; k < inputs.size(); ++k) data.inputs[k] = ModuleJet(inputs[k]);
  for (int j = 0; j < 3; ++j) data.state[StateIndex::kVx + j].v[kTwist + j] = 1.0;
  for (int i = 0; i < n; ++i) {
    data.state[StateIndex::steering(i)].v[kSteering] = 1.0;
    data.inputs[InputIndex::wheel_speed(i)].v[kWheelSpeed] = 1.0;
  }
  ModuleJet wear(0.0);
  if (model_.derivative(data.state, data.inputs, data.state_dot, data.diagnostics.data(), &wear) !=
      ModelStatus::kOk) {
    return false;
  }
  // Directions 0-2 are the twist's alone, so the sums' partials there are exact; directions 3 and 4
  // mix the modules in the sums and are read per module instead.
  for (int row = 0; row < 3; ++row) {
    const ModuleJet& rate = data.state_dot[StateIndex::kVx + row];
    point->acceleration[row] = rate.a;
    point->acceleration_per_twist.row(row) = rate.v.segment<3>(kTwist).transpose();
  }
  point->wear_rate = wear.a;
  point->wear_rate_per_twist = wear.v.segment<3>(kTwist);
  for (int i = 0; i < n; ++i) {
    const ModuleDiagnostics<ModuleJet>& module = data.diagnostics[static_cast<std::size_t>(i)];
    point->acceleration_per_steering.col(i) =
        per_force_x_.col(i) * module.fx_body.v[kSteering] + per_force_y_.col(i) * module.fy_body.v[kSteering];
    point->acceleration_per_wheel_speed.col(i) = per_force_x_.col(i) * module.fx_body.v[kWheelSpeed] +
                                                 per_force_y_.col(i) * module.fy_body.v[kWheelSpeed];
    point->wear_rate_per_steering[i] = module.wear_rate.v[kSteering];
    point->wear_rate_per_wheel_speed[i] = module.wear_rate.v[kWheelSpeed];
    point->module_wear_rate[i] = module.wear_rate.a;
    point->module_wear_rate_per_twist.col(i) = module.wear_rate.v.segment<3>(kTwist);
    point->drive_force[i] = module.fx_wheel.a;
    point->drive_force_partials.row(i) = module.fx_wheel.v.transpose();
  }
  return point->acceleration_per_twist.allFinite() && point->acceleration_per_steering.allFinite() &&
         point->acceleration_per_wheel_speed.allFinite() && std::isfinite(point->wear_rate) &&
         point->wear_rate_per_twist.allFinite() && point->wear_rate_per_steering.allFinite() &&
         point->wear_rate_per_wheel_speed.allFinite() && point->module_wear_rate_per_twist.allFinite() &&
         point->drive_force_partials.allFinite();
}

}  // namespace swerve
