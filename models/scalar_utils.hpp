// Internal helpers shared by the templated models (double and ceres::Jet): the value part of a
// scalar, finiteness checks, smooth max. Not installed.
#pragma once

#include <cmath>
#include <limits>

#include "swerve/core/scalar.hpp"

namespace swerve::detail {

using swerve::scalar_value;

template <typename T>
bool is_finite(const T& v) {
  return std::isfinite(scalar_value(v));
}

// max(a, b) smoothed: (a + b + sqrt((a - b)^2 + d^2)) / 2 >= max(a, b), within d/2 of it.
template <typename T>
T smooth_max(const T& a, const T& b, double d) {
  using std::sqrt;
  const T diff = a - b;
  return T(0.5) * (a + b + sqrt(diff * diff + T(d * d)));
}

template <typename T>
T clamp_value(const T& v, double lo, double hi) {
  if (scalar_value(v) < lo) return T(lo);
  if (scalar_value(v) > hi) return T(hi);
  return v;
}

inline constexpr double kQuietNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace swerve::detail
