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

const OptionFields<WearParams>& WearParams::fields() {
  static const OptionFields<WearParams> table{
      {"coefficient", &WearParams::coefficient, Bound::positive()},
      {"smoothing", &WearParams::smoothing, Bound::non_negative()},
  };
  return table;
}

void WearParams::validate() const { check_fields("WearParams", *this, fields()); }

}  // namespace swerve
