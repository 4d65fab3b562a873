// Limits for code templated on the scalar (double, or ceres::Jet for exact derivatives): a clamp
// whose bounds are chosen on values, and C1 blends of min, max and clamp. The blends are what the
// prediction's module map and step are built from, so every optimiser differentiates one smooth map.
#pragma once

#include "swerve/core/scalar.hpp"

namespace swerve {

// `value` limited to [lower, upper], the bounds chosen on values (a Jet keeps the derivative of
// whichever side is active).
template <typename T>
T clamp_by_value(const T& value, const T& lower, const T& upper) {
  if (scalar_value(value) < scalar_value(lower)) return lower;
  if (scalar_value(value) > scalar_value(upper)) return upper;
  return value;
}

// Smooth saturations for the limits inside the prediction. A hard clamp has a kink where it becomes
// active, and a gradient method whose iterates cross it sees linearisations that are wrong on one
// side (Ipopt stalled with dynamics defects of 1e-2 at the stages where the steering-rate limit
// switched on or off). min(x, limit) is replaced by a C1 blend over [limit - width, limit + width]:
// x - (x - limit + width)^2 / (4 width) there, exactly x below it and exactly the limit above it,
// so motion away from the limits is unchanged.
template <typename T>
T soft_min(const T& x, double limit, double width) {
  const double value = scalar_value(x);
  if (value <= limit - width) return x;
  if (value >= limit + width) return T(limit);
  const T excess = x - (limit - width);
  return x - excess * excess / (4.0 * width);
}
template <typename T>
T soft_max(const T& x, double limit, double width) {
  return -soft_min<T>(-x, -limit, width);
}
template <typename T>
T soft_clamp(const T& x, double lower, double upper, double width) {
  return soft_min<T>(soft_max<T>(x, lower, width), upper, width);
}

}  // namespace swerve
