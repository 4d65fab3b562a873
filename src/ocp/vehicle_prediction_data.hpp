// VehiclePredictionModel's caller-owned scratch (its Data's Impl).
#pragma once

#include <Eigen/Core>

#include "swerve/models/semi_implicit_step.hpp"
#include "swerve/models/semi_implicit_step_jacobian.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {

// The double step's scratch, the module inputs a twist_step maps to, and the Jacobian's scratch.
struct VehiclePredictionModel::Data::Impl {
  Impl(const SemiImplicitStep<double>& step, const SemiImplicitStepJacobian& step_jacobian)
      : values(step), inputs(Eigen::VectorXd::Zero(step.model().input_size())), jacobian(step_jacobian) {}
  SemiImplicitStep<double>::Data values;
  Eigen::VectorXd inputs;
  SemiImplicitStepJacobian::Data jacobian;
};

}  // namespace swerve
