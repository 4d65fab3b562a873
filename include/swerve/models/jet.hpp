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

extern template class MagicFormulaTire<ModelJet>;
extern template class VehicleModel<ModelJet>;
extern template class DiscreteDynamics<ModelJet>;
extern template WheelSlip<ModelJet> compute_wheel_slip<ModelJet>(const MagicFormulaParams&, ModelJet,
                                                                  ModelJet, ModelJet);

}  // namespace swerve
