// The numbers just outside a Bound, one per bounded side: the edge itself where it is open, one
// beyond it where it is closed. The option-table tests set each in YAML and in code.
#pragma once

#include <vector>

#include "swerve/core/option_fields.hpp"

namespace swerve::testing {

inline std::vector<double> values_just_outside(const Bound& bound) {
  std::vector<double> outside;
  if (bound.has_lower()) outside.push_back(bound.lower_open ? bound.lower : bound.lower - 1.0);
  if (bound.has_upper()) outside.push_back(bound.upper_open ? bound.upper : bound.upper + 1.0);
  return outside;
}

}  // namespace swerve::testing
