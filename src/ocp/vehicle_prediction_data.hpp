// VehiclePredictionModel's caller-owned scratch (its Data's Impl), shared by the two units that
// step the model: vehicle_prediction_model.cpp in double, prediction_jacobians.cpp in Jets.
#pragma once

#include <memory>

#include "swerve/models/semi_implicit_step.hpp"
#include "swerve/ocp/vehicle_prediction_model.hpp"

namespace swerve {

// The double step's scratch, the module inputs a twist_step maps to, and the Jet twin's scratch
// for the Jacobians.
struct VehiclePredictionModel::Data::Impl {
  Impl(const SemiImplicitStep<double>& step, std::unique_ptr<detail::JetScratch, detail::JetScratchDeleter> jet_scratch)
      : values(step), inputs(Eigen::VectorXd::Zero(step.model().input_size())), jets(std::move(jet_scratch)) {}
  SemiImplicitStep<double>::Data values;
  Eigen::VectorXd inputs;
  std::unique_ptr<detail::JetScratch, detail::JetScratchDeleter> jets;
};

}  // namespace swerve
