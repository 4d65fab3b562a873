// The value part of a scalar that may be a double or a ceres::Jet (its .a, recursively), for code
// templated on the scalar type that must branch on values (clamps, branches, wraps) and let the
// derivative of the chosen branch through.
#pragma once

namespace swerve {

inline double scalar_value(double v) { return v; }
template <typename Jet>
double scalar_value(const Jet& j) {
  return scalar_value(j.a);
}

}  // namespace swerve
