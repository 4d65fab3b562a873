#include "swerve/models/tire_wear.hpp"

#include <cmath>
#include <sstream>

#include "swerve/core/config_error.hpp"

namespace swerve {

const char* to_string(WearModelKind kind) {
  switch (kind) {
    case WearModelKind::kFrictionalPower: return "frictional_power";
    case WearModelKind::kArchard: return "archard";
  }
  return "unknown";
}

void WearParams::validate() const {
  auto reject = [](const char* field, double value, const char* rule) {
    std::ostringstream message;
    message << "WearParams." << field << " = " << value << ": " << rule;
    throw ConfigError(message.str());
  };
  if (!std::isfinite(coefficient) || coefficient <= 0.0) reject("coefficient", coefficient, "must be finite and > 0");
  if (!std::isfinite(smoothing) || smoothing < 0.0) reject("smoothing", smoothing, "must be finite and >= 0");
}

}  // namespace swerve
