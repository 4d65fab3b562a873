// Tire wear: the frictional power dissipated in each contact patch and the wear rate derived from
// it (docs/paper.md, assumption 5; the paper's "simplified tire wear model" is not published, so the
// frictional-power form is ours). Header-only templates, valid for double and ceres::Jet.
#pragma once

#include <cmath>

#include "swerve/core/option_fields.hpp"
#include "swerve/models/magic_formula_tire.hpp"

namespace swerve {

enum class WearModelKind {
  // w_dot = k (|Fx (V_r - u)| + |Fy v|): energy (Schallamach-type) wear; k in wear units per joule.
  kFrictionalPower,
  // w_dot = k Fz |v_slip|: Archard-type wear, load times sliding speed; k in wear units per (N m).
  kArchard,
};

const char* to_string(WearModelKind kind);  // "frictional_power", "archard"

struct WearParams {
  WearModelKind model = WearModelKind::kFrictionalPower;
  // k. 1.0 by default: the paper reports only wear ratios (docs/paper.md, assumption 5), so with the
  // frictional-power model the wear is the dissipated energy in joules.
  double coefficient = 1.0;
  // Smoothing of |.| for gradient solvers: |z| -> sqrt(z^2 + s^2) - s (zero at zero, smooth, within
  // s of |z|). Units: W for kFrictionalPower (applied to each power term), m/s for kArchard
  // (applied to the sliding speed). 0 (default) gives the exact |.|; for the frictional-power model
  // with our Magic Formula tire each power term is >= 0 and vanishes quadratically at zero slip, so
  // the exact form is already smooth there.
  double smoothing = 0.0;

  // Throws ConfigError naming the field and value.
  static const OptionFields<WearParams>& fields();  // the rules, read by the YAML loader too
  void validate() const;
};

// |z| smoothed as sqrt(z^2 + s^2) - s (exact |z| for s = 0).
template <typename T>
T smooth_abs(const T& z, double smoothing) {
  using std::abs;
  using std::sqrt;
  if (smoothing <= 0.0) return abs(z);
  return sqrt(z * z + T(smoothing * smoothing)) - T(smoothing);
}

// Power dissipated in the contact patch (W): |Fx (V_r - u)| + |Fy v| (docs/paper.md, assumption 5),
// with slip velocities as in WheelSlip (wheel frame).
template <typename T>
T frictional_power(const TireForces<T>& forces, const WheelSlip<T>& slip, double smoothing = 0.0) {
  return smooth_abs(T(forces.fx_wheel * slip.slip_velocity_x_wheel), smoothing) +
         smooth_abs(T(forces.fy_wheel * slip.slip_velocity_y_wheel), smoothing);
}

// Wear rate of one tire (wear units per second, >= 0).
template <typename T>
T wear_rate(const WearParams& params, const TireForces<T>& forces, const WheelSlip<T>& slip, const T& fz) {
  using std::sqrt;
  if (params.model == WearModelKind::kFrictionalPower) {
    return T(params.coefficient) * frictional_power(forces, slip, params.smoothing);
  }
  const T sliding_sq = slip.slip_velocity_x_wheel * slip.slip_velocity_x_wheel +
                       slip.slip_velocity_y_wheel * slip.slip_velocity_y_wheel;
  const double s = params.smoothing;
  // Smoothed |v_slip| = sqrt(|v|^2 + s^2) - s; with s = 0 a tiny floor keeps sqrt differentiable at 0.
  const T speed = s > 0.0 ? T(sqrt(sliding_sq + T(s * s)) - T(s)) : T(sqrt(sliding_sq + T(1e-24)) - T(1e-12));
  const T load = fz > T(0.0) ? fz : T(0.0);
  return T(params.coefficient) * load * speed;
}

}  // namespace swerve
