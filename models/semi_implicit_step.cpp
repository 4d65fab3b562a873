#include "swerve/models/semi_implicit_step.hpp"

#include <sstream>

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

}  // namespace swerve
