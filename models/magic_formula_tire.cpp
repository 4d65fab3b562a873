#include "swerve/models/magic_formula_tire.hpp"

#include <cmath>

#include "magic_formula_tire_impl.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kHalfPi = 1.57079632679489661923;

}  // namespace

const OptionFields<MagicFormulaCoefficients>& MagicFormulaCoefficients::fields() {
  static const OptionFields<MagicFormulaCoefficients> table{
      {"B", &MagicFormulaCoefficients::b, Bound::positive()},
      {"C", &MagicFormulaCoefficients::c, Bound::open(0.0, 2.0), {}, nullptr,
       "(the force must not reverse sign at large slip)"},
      // Pacejka's condition for a single peak.
      {"E", &MagicFormulaCoefficients::e, Bound{-1e308, 1.0, false, false}},
      {"mu", &MagicFormulaCoefficients::mu, Bound::positive()},
  };
  return table;
}

const OptionFields<MagicFormulaParams>& MagicFormulaParams::fields() {
  static const OptionFields<MagicFormulaParams> table{
      {"mu", &MagicFormulaParams::mu, Bound::positive()},
      {"slip_speed_epsilon", &MagicFormulaParams::slip_speed_epsilon, Bound::positive()},
      {"smooth_slip", &MagicFormulaParams::smooth_slip},
  };
  return table;
}

const char* to_string(CombinedSlipMethod method) {
  switch (method) {
    case CombinedSlipMethod::kNone: return "none";
    case CombinedSlipMethod::kEllipseCap: return "ellipse_cap";
    case CombinedSlipMethod::kNormalizedSlip: return "normalized_slip";
  }
  return "unknown";
}

void MagicFormulaParams::validate() const {
  check_fields("MagicFormulaParams", *this, fields());
  check_fields("MagicFormulaParams.longitudinal", longitudinal, MagicFormulaCoefficients::fields());
  check_fields("MagicFormulaParams.lateral", lateral, MagicFormulaCoefficients::fields());
}

double magic_formula_peak_slip(const MagicFormulaCoefficients& k) {
  if (k.c <= 1.0) return 1.0 / k.b;  // sin(C atan(.)) rises monotonically to sin(C pi/2): no peak
  // Peak where C atan(y - E (y - atan y)) = pi/2 with y = B x: solve h(y) = y - E (y - atan y) - t = 0,
  // t = tan(pi / (2C)); h is increasing for E <= 1, so bisect.
  const double t = std::tan(kHalfPi / k.c);
  auto h = [&](double y) { return y - k.e * (y - std::atan(y)) - t; };
  double lo = 0.0;
  double hi = 1.0;
  while (h(hi) < 0.0) {
    hi *= 2.0;
    if (hi > 1e12) return 1.0 / k.b;  // E = 1 with t >= pi/2: no finite peak
  }
  for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (h(mid) < 0.0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi) / k.b;
}

template WheelSlip<double> compute_wheel_slip<double>(const MagicFormulaParams&, double, double, double);
template class MagicFormulaTire<double>;

}  // namespace swerve
