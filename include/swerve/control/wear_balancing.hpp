// Wear balancing: each module's accumulated tire wear (or tread worn) turned into a weight on that
// module's own wear in the prediction's stage wear (PredictionModel::observe_wear_weights), so
// that the optimiser spares the most worn tires and a vehicle's tires wear out together.
#pragma once

#include "swerve/core/option_fields.hpp"

namespace swerve {

struct WearBalancingOptions {
  bool enabled = false;
  // Module i's weight before the bounds: (W_i / W_bar)^exponent, W_i its accumulated wear and W_bar
  // the vehicle's mean (each module's weighed by its share of the static load). With linear tires a
  // weight w moves a share of force away until that module's frictional power falls as 1 / w^2.
  double exponent = 1.0;
  // Bounds on a weight: a new tire's wear still costs something, a worn one's not everything.
  double min_weight = 0.25;
  double max_weight = 4.0;
  static const OptionFields<WearBalancingOptions>& fields();
  void validate() const;  // throws ConfigError naming the field and value
};

// The n weights for accumulated wear `wear` (n entries, finite and >= 0) on modules carrying
// `load_shares` of the static load (n entries summing to 1): (W_i / W_bar)^exponent scaled so
// their load-weighted mean is 1, then held within [min_weight, max_weight]; all 1 while W_bar is
// 0 (new tires). noexcept, no allocation.
void wear_balancing_weights(const WearBalancingOptions& options, const double* wear,
                            const double* load_shares, int n, double* weights) noexcept;

}  // namespace swerve
