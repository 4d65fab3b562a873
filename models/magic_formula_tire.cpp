#include "swerve/models/magic_formula_tire.hpp"

#include <cmath>
#include <sstream>

#include "magic_formula_tire_impl.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kHalfPi = 1.57079632679489661923;

[[noreturn]] void reject(const std::string& field, double value, const std::string& rule) {
  throw_invalid_field("MagicFormulaParams", field, value, rule);
}

void check_channel(const std::string& name, const MagicFormulaCoefficients& k) {
  if (!std::isfinite(k.b) || k.b <= 0.0) reject(name + ".B", k.b, "must be finite and > 0");
  if (!std::isfinite(k.c) || k.c <= 0.0 || k.c >= 2.0) {
    reject(name + ".C", k.c, "must be in (0, 2) (the force must not reverse sign at large slip)");
  }
  if (!std::isfinite(k.e) || k.e > 1.0) reject(name + ".E", k.e, "must be finite and <= 1");
  if (k.mu && (!std::isfinite(*k.mu) || *k.mu <= 0.0)) reject(name + ".mu", *k.mu, "must be finite and > 0");
}

}  // namespace

const char* to_string(CombinedSlipMethod method) {
  switch (method) {
    case CombinedSlipMethod::kNone: return "none";
    case CombinedSlipMethod::kEllipseCap: return "ellipse_cap";
    case CombinedSlipMethod::kNormalizedSlip: return "normalized_slip";
  }
  return "unknown";
}

void MagicFormulaParams::validate() const {
  if (!std::isfinite(mu) || mu <= 0.0) reject("mu", mu, "must be finite and > 0");
  check_channel("longitudinal", longitudinal);
  check_channel("lateral", lateral);
  if (!std::isfinite(slip_speed_epsilon) || slip_speed_epsilon <= 0.0) {
    reject("slip_speed_epsilon", slip_speed_epsilon, "must be finite and > 0");
  }
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
