#include "swerve/models/vehicle_model.hpp"

#include "vehicle_model_impl.hpp"

namespace swerve {

const char* to_string(ModelStatus status) {
  switch (status) {
    case ModelStatus::kOk: return "ok";
    case ModelStatus::kNonFiniteState: return "non_finite_state";
    case ModelStatus::kNonFiniteInput: return "non_finite_input";
    case ModelStatus::kNonFiniteResult: return "non_finite_result";
    case ModelStatus::kInvalidArgument: return "invalid_argument";
  }
  return "unknown";
}

template class VehicleModel<double>;

}  // namespace swerve
