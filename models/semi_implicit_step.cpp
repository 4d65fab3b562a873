#include "swerve/models/semi_implicit_step.hpp"

#include "swerve/core/config_error.hpp"

namespace swerve {

const char* to_string(PredictionMethod method) noexcept {
  return method == PredictionMethod::kSemiImplicit ? "semi_implicit" : "rk4";
}

const OptionFields<PredictionOptions>& PredictionOptions::fields() {
  static const OptionFields<PredictionOptions> table{
      {"substeps", &PredictionOptions::substeps, Bound::closed(1, 1000)},
      {"slow_substeps", &PredictionOptions::slow_substeps, Bound::closed(1, 1000)},
      {"max_newton_iterations", &PredictionOptions::max_newton_iterations, Bound::closed(1, 100)},
      {"drive_lag", &PredictionOptions::drive_lag},
      {"steering_lag", &PredictionOptions::steering_lag},
  };
  return table;
}

void PredictionOptions::validate() const { check_fields("PredictionOptions", *this, fields()); }

}  // namespace swerve
