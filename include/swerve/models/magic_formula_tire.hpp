// Pacejka Magic Formula tire (pure slip per channel, plus combined slip) and the regularised slip
// definitions that keep every quantity finite down to a wheel at rest. Templated on the scalar so
// ceres::Jet gives exact derivatives; instantiated for double and swerve::ModelJet (models/jet.hpp).
#pragma once

#include <cmath>
#include <optional>
#include <string>

#include "swerve/core/option_fields.hpp"

namespace swerve {

// How the longitudinal and lateral forces interact when the wheel drives/brakes and corners at once.
enum class CombinedSlipMethod {
  // Pure slip: Fx from the slip ratio alone, Fy from the slip angle alone (the paper's model,
  // docs/paper.md, "Tires": no combined slip was seen). Forces may leave the friction ellipse.
  kNone,
  // Friction-ellipse cap (docs/paper.md, assumption 4, "optional friction-circle cap", generalised to
  // an ellipse with semi-axes Dx, Dy): the pure-slip forces are scaled by 1/max(1, rho) with
  // rho = sqrt((Fx0/Dx)^2 + (Fy0/Dy)^2). Published and simple, but has a kink at rho = 1, so it is
  // meant for the plant, not for gradient solvers.
  kEllipseCap,
  // Normalised combined slip, the similarity method of Pacejka, "Tire and Vehicle Dynamics", 3rd ed.
  // (2012), sec. 4.3.2 (after Bakker, Nyborg & Pacejka 1987): slips are normalised by their
  // pure-slip peak values, s_x = kappa/kappa_peak, s_y = alpha/alpha_peak, s = |(s_x, s_y)|, and
  //   Fx = Dx f_x(s) s_x / s,   Fy = Dy f_y(s) s_y / s,   f(s) = sin(C atan(B x_pk s - E(...))).
  // It reduces exactly to the pure-slip curves on each axis, (Fx/Dx)^2 + (Fy/Dy)^2 = ... <= 1
  // everywhere, and it is C-infinity (f(s)/s is even and analytic in s), so this is the smooth
  // variant for gradient solvers. The default.
  kNormalizedSlip,
};

const char* to_string(CombinedSlipMethod method);  // "none", "ellipse_cap", "normalized_slip"

// One channel of F = D sin(C atan(B x - E (B x - atan(B x)))), D = mu Fz (Pacejka 2012, eq. 4.49).
struct MagicFormulaCoefficients {
  double b = 10.0;   // stiffness factor (1/unit of slip)
  double c = 1.65;   // shape factor; (0, 2) so the force never reverses sign
  double e = 0.0;    // curvature factor; finite and <= 1 (Pacejka's condition for a single peak)
  // This channel's own peak friction coefficient (Pacejka's mu_x or mu_y, D = mu Fz), e.g. for a
  // tread that grips differently along and across; unset: MagicFormulaParams::mu.
  std::optional<double> mu{};  // (braced, so {B, C, E} aggregate initialisation stays warning-free)

  // The rules (YAML keys B, C, E, mu), read by the loader too; MagicFormulaParams::validate()
  // checks each channel by them.
  static const OptionFields<MagicFormulaCoefficients>& fields();
};

struct MagicFormulaParams {
  double mu = 0.8;   // peak friction coefficient, D = mu Fz, of both channels unless one sets its own (assumption 4)
  MagicFormulaCoefficients longitudinal{10.0, 1.65, 0.0};  // x = slip ratio kappa (assumption 4)
  MagicFormulaCoefficients lateral{15.0, 1.3, 0.0};        // x = slip angle alpha, rad (assumption 4)
  CombinedSlipMethod combined_slip = CombinedSlipMethod::kNormalizedSlip;
  // Slip regularisation speed eps (m/s, docs/paper.md, assumption 3, eps = 0.05).
  double slip_speed_epsilon = 0.05;
  // true: the smooth regularisation of the slip denominators (see compute_wheel_slip); false: the
  // exact max() form of assumption 3 (kinks at |u| = eps and |V_r| = |u|).
  bool smooth_slip = true;

  // Each channel's peak friction coefficient: its own mu, or the common one.
  double mu_longitudinal() const { return longitudinal.mu.value_or(mu); }
  double mu_lateral() const { return lateral.mu.value_or(mu); }

  // The rules of mu, slip_speed_epsilon and smooth_slip (the loader reads them from the same table).
  static const OptionFields<MagicFormulaParams>& fields();
  // Throws ConfigError naming the field, its value and the rule ("MagicFormulaParams.mu = 0: must
  // be finite and > 0", "MagicFormulaParams.lateral.C = 2: must be in (0, 2) ...").
  void validate() const;
};

// Wheel-frame quantities: x along the wheel's rolling direction, y to its left, z up.
template <typename T>
struct TireForces {
  T fx_wheel{0.0};  // N, longitudinal (positive drives the wheel forward)
  T fy_wheel{0.0};  // N, lateral
};

template <typename T>
struct WheelSlip {
  T slip_ratio{0.0};  // kappa, dimensionless, in [-2, 2]
  T slip_angle{0.0};  // alpha, rad, in (-pi/2, pi/2)
  // Sliding velocity of the ground relative to the tread at the contact, wheel frame (m/s):
  // (V_r - u, -v). The tire force points along it, so the power dissipated in the contact is
  // Fx * slip_velocity_x + Fy * slip_velocity_y >= 0.
  T slip_velocity_x_wheel{0.0};
  T slip_velocity_y_wheel{0.0};
  // The speeds the slips are normalised by: slip_velocity_x = slip_ratio * slip_ratio_speed and
  // slip_velocity_y = tan(slip_angle) * slip_angle_speed (m/s, > 0).
  T slip_ratio_speed{0.0};
  T slip_angle_speed{0.0};
};

// The contact's sliding when the tire force comes from transient slips (kappa', alpha'; the plant's
// relaxation length) instead of the wheel's kinematic slips: the sliding velocity those slips stand
// for, kappa' and tan(alpha') times the kinematic slips' normalising speeds. The rest of the
// wheel-ground speed difference deflects the carcass (Pacejka 2012, sec. 7.2: the contact point
// slides at V kappa' while the deflection takes up the difference); that energy is stored and given
// back, not worn away. Equals `kinematic` in steady state (kappa' = kappa, alpha' = alpha).
template <typename T>
WheelSlip<T> transient_sliding(const WheelSlip<T>& kinematic, const T& transient_ratio, const T& transient_angle) {
  using std::tan;
  WheelSlip<T> sliding = kinematic;
  sliding.slip_ratio = transient_ratio;
  sliding.slip_angle = transient_angle;
  sliding.slip_velocity_x_wheel = transient_ratio * kinematic.slip_ratio_speed;
  sliding.slip_velocity_y_wheel = tan(transient_angle) * kinematic.slip_angle_speed;
  return sliding;
}

// Slip of a wheel whose contact point moves at (u, v) in the wheel frame while its tread moves at
// V_r = wheel_radius * wheel_speed (docs/paper.md, assumption 3):
//   kappa = (V_r - u) / max(|V_r|, |u|, eps),   alpha = -atan2(v, max(|u|, eps)).
// Smooth form (params.smooth_slip, the default; our regularisation of assumption 3):
//   kappa = (V_r - u) / ((|u|_e + |V_r|_e) / 2),   alpha = -atan(v / |u|_e),   |z|_e = sqrt(z^2 + eps^2),
// i.e. the max of the two speeds is replaced by their smoothed mean. It agrees with the max form
// to first order at small slip (same cornering/driving stiffness at the origin), keeps |kappa| <= 2,
// and is C-infinity with curvature scale eps (a smoothed max would have a much sharper kink at
// |V_r| = |u|, exactly at pure rolling). Both forms have denominators >= eps > 0, so kappa and
// alpha are finite everywhere, including a wheel at rest; kappa = alpha = 0 exactly when V_r = u
// and v = 0 (pure rolling).
template <typename T>
WheelSlip<T> compute_wheel_slip(const MagicFormulaParams& params, T u_wheel, T v_wheel, T tread_speed);

template <typename T>
class MagicFormulaTire {
 public:
  // Validates the parameters (throws ConfigError) and precomputes the peak slips.
  explicit MagicFormulaTire(const MagicFormulaParams& params);

  // Wheel-frame forces for slip ratio kappa, slip angle alpha (rad) and normal load fz (N, >= 0;
  // a negative load is treated as 0, a lifted wheel). Fx has the sign of kappa, Fy the sign of
  // alpha (alpha > 0 when the wheel slides to its right, so Fy > 0 pushes it left).
  TireForces<T> forces(T slip_ratio, T slip_angle, T fz) const;

  // Pure-slip channels, F = D sin(C atan(B x - E (B x - atan B x))).
  T pure_longitudinal(T slip_ratio, T fz) const;
  T pure_lateral(T slip_angle, T fz) const;

  const MagicFormulaParams& params() const { return params_; }
  // Slip at which the pure-slip force peaks (= D); for C <= 1 the curve has no peak and this is 1/B.
  double peak_slip_ratio() const { return peak_x_; }
  double peak_slip_angle() const { return peak_y_; }

 private:
  MagicFormulaParams params_;
  double peak_x_;
  double peak_y_;
};

// The slip x at which C atan(B x - E (B x - atan B x)) = pi/2 (the peak); 1/B when C <= 1.
double magic_formula_peak_slip(const MagicFormulaCoefficients& coefficients);

}  // namespace swerve
