// Internal helpers shared by the templated models (double and ceres::Jet): the value part of a
// scalar and finiteness checks (the clamps and blends are core/smoothing.hpp). Not installed.
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

inline constexpr double kQuietNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace swerve::detail
