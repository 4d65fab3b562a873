#include "swerve/control/wear_balancing.hpp"

#include <algorithm>
#include <cmath>

namespace swerve {

const OptionFields<WearBalancingOptions>& WearBalancingOptions::fields() {
  // Direct-list-initialised: with `= {` and a bool field GCC 12 stops with an internal error.
  static const OptionFields<WearBalancingOptions> table{
      {"enabled", &WearBalancingOptions::enabled},
      {"exponent", &WearBalancingOptions::exponent, Bound::closed(0.0, 10.0)},
      {"wear_offset", &WearBalancingOptions::wear_offset, Bound::non_negative(), {}, nullptr, "(wear units)"},
      {"min_weight", &WearBalancingOptions::min_weight, Bound::half_open(0.0, 1.0)},
      {"max_weight", &WearBalancingOptions::max_weight, Bound::closed(1.0, 100.0)},
  };
  return table;
}

void WearBalancingOptions::validate() const { check_fields("WearBalancingOptions", *this, fields()); }

void wear_balancing_weights(const WearBalancingOptions& options, const double* wear, const double* load_shares, int n,
                            double* weights) noexcept {
  // Ratios to the largest wear first, so that wear near the largest double cannot overflow the mean.
  double largest = options.wear_offset;
  for (int i = 0; i < n; ++i) largest = std::max(largest, wear[i] + options.wear_offset);
  double mean_wear = 0.0;
  for (int i = 0; i < n; ++i) mean_wear += load_shares[i] * ((wear[i] + options.wear_offset) / largest);
  std::fill(weights, weights + n, 1.0);
  if (!(mean_wear > 0.0) || !std::isfinite(mean_wear)) return;
  double mean_weight = 0.0;
  for (int i = 0; i < n; ++i) {
    weights[i] = std::pow((wear[i] + options.wear_offset) / largest / mean_wear, options.exponent);
    mean_weight += load_shares[i] * weights[i];
  }
  for (int i = 0; i < n; ++i) {
    const double weight = std::clamp(weights[i] / mean_weight, options.min_weight, options.max_weight);
    weights[i] = std::isfinite(weight) ? weight : 1.0;
  }
}

}  // namespace swerve
