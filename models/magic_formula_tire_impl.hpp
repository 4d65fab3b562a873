// Template definitions of MagicFormulaTire and compute_wheel_slip, included by the .cpp files that
// instantiate them (double in magic_formula_tire.cpp, the Jet in jet_instantiations.cpp).
#pragma once

#include <cmath>

#include "scalar_utils.hpp"
#include "swerve/models/magic_formula_tire.hpp"

namespace swerve {
namespace detail {

// sin(C atan(B x - E (B x - atan(B x)))), the normalised Magic Formula (Pacejka 2012, eq. 4.49).
// With E = 0 (every shipped tyre) the curvature term is exactly zero, value and derivatives, so
// its arctangent is skipped: one of the five per module and evaluation, the same bits.
template <typename T>
T magic_formula_curve(const MagicFormulaCoefficients& k, const T& x) {
  using std::atan;
  using std::sin;
  const T bx = k.b * x;
  if (k.e == 0.0) return sin(k.c * atan(bx));
  return sin(k.c * atan(bx - k.e * (bx - atan(bx))));
}

}  // namespace detail

template <typename T>
WheelSlip<T> compute_wheel_slip(const MagicFormulaParams& params, T u_wheel, T v_wheel, T tread_speed) {
  using std::abs;
  using std::atan;
  using std::sqrt;
  const double eps = params.slip_speed_epsilon;
  T denom_kappa;
  T denom_alpha;
  if (params.smooth_slip) {
    const T abs_u = sqrt(u_wheel * u_wheel + T(eps * eps));
    const T abs_vr = sqrt(tread_speed * tread_speed + T(eps * eps));
    denom_kappa = T(0.5) * (abs_u + abs_vr);
    denom_alpha = abs_u;
  } else {
    const T abs_u = abs(u_wheel);
    const T abs_vr = abs(tread_speed);
    denom_kappa = scalar_value(abs_u) > scalar_value(abs_vr) ? abs_u : abs_vr;
    if (scalar_value(denom_kappa) < eps) denom_kappa = T(eps);
    denom_alpha = scalar_value(abs_u) < eps ? T(eps) : abs_u;
  }
  WheelSlip<T> slip;
  slip.slip_velocity_x_wheel = tread_speed - u_wheel;
  slip.slip_velocity_y_wheel = -v_wheel;
  slip.slip_ratio = slip.slip_velocity_x_wheel / denom_kappa;
  slip.slip_angle = -atan(v_wheel / denom_alpha);  // = -atan2(v, denom) for denom > 0
  slip.slip_ratio_speed = denom_kappa;
  slip.slip_angle_speed = denom_alpha;
  return slip;
}

template <typename T>
MagicFormulaTire<T>::MagicFormulaTire(const MagicFormulaParams& params)
    : params_(params),
      peak_x_((params.validate(), magic_formula_peak_slip(params.longitudinal))),
      peak_y_(magic_formula_peak_slip(params.lateral)) {}

template <typename T>
T MagicFormulaTire<T>::pure_longitudinal(T slip_ratio, T fz) const {
  const T load = scalar_value(fz) > 0.0 ? fz : T(0.0);
  return params_.mu_longitudinal() * load * detail::magic_formula_curve(params_.longitudinal, slip_ratio);
}

template <typename T>
T MagicFormulaTire<T>::pure_lateral(T slip_angle, T fz) const {
  const T load = scalar_value(fz) > 0.0 ? fz : T(0.0);
  return params_.mu_lateral() * load * detail::magic_formula_curve(params_.lateral, slip_angle);
}

template <typename T>
TireForces<T> MagicFormulaTire<T>::forces(T slip_ratio, T slip_angle, T fz) const {
  using std::sqrt;
  TireForces<T> out;
  const T load = scalar_value(fz) > 0.0 ? fz : T(0.0);
  // D per channel; the combined forces stay inside the friction ellipse with semi-axes dx, dy.
  const T dx = params_.mu_longitudinal() * load;
  const T dy = params_.mu_lateral() * load;
  switch (params_.combined_slip) {
    case CombinedSlipMethod::kNone:
      out.fx_wheel = dx * detail::magic_formula_curve(params_.longitudinal, slip_ratio);
      out.fy_wheel = dy * detail::magic_formula_curve(params_.lateral, slip_angle);
      return out;
    case CombinedSlipMethod::kEllipseCap: {
      out.fx_wheel = dx * detail::magic_formula_curve(params_.longitudinal, slip_ratio);
      out.fy_wheel = dy * detail::magic_formula_curve(params_.lateral, slip_angle);
      if (scalar_value(load) <= 0.0) return out;
      const T rho_sq = out.fx_wheel * out.fx_wheel / (dx * dx) + out.fy_wheel * out.fy_wheel / (dy * dy);
      if (scalar_value(rho_sq) > 1.0) {
        const T scale = T(1.0) / sqrt(rho_sq);
        out.fx_wheel *= scale;
        out.fy_wheel *= scale;
      }
      return out;
    }
    case CombinedSlipMethod::kNormalizedSlip:
    default: {
      const T sx = slip_ratio / peak_x_;
      const T sy = slip_angle / peak_y_;
      const T s_sq = sx * sx + sy * sy;
      T gx;  // f_x(s) / s
      T gy;  // f_y(s) / s
      if (scalar_value(s_sq) < 1e-20) {
        // f(s)/s -> d f / d s at 0 = C B x_peak (the E term is cubic), error O(s^2) < 1e-20.
        gx = T(params_.longitudinal.c * params_.longitudinal.b * peak_x_);
        gy = T(params_.lateral.c * params_.lateral.b * peak_y_);
      } else {
        const T s = sqrt(s_sq);
        gx = detail::magic_formula_curve(params_.longitudinal, T(peak_x_ * s)) / s;
        gy = detail::magic_formula_curve(params_.lateral, T(peak_y_ * s)) / s;
      }
      out.fx_wheel = dx * gx * sx;
      out.fy_wheel = dy * gy * sy;
      return out;
    }
  }
}

}  // namespace swerve
