// The one ceres::Jet type the models are instantiated for, for code that differentiates them
// directly (tests, custom solvers). Including it needs Ceres' headers on the include path; the
// rest of swerve/models/ does not.
#pragma once

#include <ceres/jet.h>

#include "swerve/models/integrators.hpp"
#include "swerve/models/magic_formula_tire.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

inline constexpr int kModelJetSize = 8;  // directions per evaluation (chunks of the nx + nu inputs)
using ModelJet = ceres::Jet<double, kModelJetSize>;

// Three directions: derivatives along the body twist alone (the Jacobian of the prediction step's
// backward-Euler residual in its Newton solve).
using TwistJet = ceres::Jet<double, 3>;

// Five directions: one module's own variables (the body twist, its steering angle, its wheel
// speed), for the model's linearisation per module (model_linearisation.hpp).
using ModuleJet = ceres::Jet<double, 5>;

extern template class MagicFormulaTire<ModelJet>;
extern template class VehicleModel<ModelJet>;
extern template class DiscreteDynamics<ModelJet>;
extern template WheelSlip<ModelJet> compute_wheel_slip<ModelJet>(const MagicFormulaParams&, ModelJet,
                                                                  ModelJet, ModelJet);
extern template class MagicFormulaTire<TwistJet>;
extern template class VehicleModel<TwistJet>;
extern template WheelSlip<TwistJet> compute_wheel_slip<TwistJet>(const MagicFormulaParams&, TwistJet,
                                                                  TwistJet, TwistJet);
extern template class MagicFormulaTire<ModuleJet>;
extern template class VehicleModel<ModuleJet>;
extern template WheelSlip<ModuleJet> compute_wheel_slip<ModuleJet>(const MagicFormulaParams&, ModuleJet,
                                                                    ModuleJet, ModuleJet);

}  // namespace swerve
