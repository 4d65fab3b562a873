// Wear balancing: each module's accumulated tire wear (or tread worn) turned into a weight on that
// module's own wear in the prediction's stage wear (PredictionModel::observe_wear_weights), so that
// a plan which wears a worn tire costs more. Whether the optimiser can then spare it depends on
// the levers it has: docs/decisions/wear-balancing.md.
#pragma once

#include "swerve/core/option_fields.hpp"

namespace swerve {

struct WearBalancingOptions {
  bool enabled = false;
  // Module i's weight before the bounds: ((W_i + offset) / (W_bar + offset))^exponent, W_i its
  // accumulated wear and W_bar the vehicle's mean (each module's weighed by its share of the static
  // load).
  double exponent = 1.0;
  // Wear units added to every tire's wear: tires that have all worn little against it weigh nearly
  // alike, so the first joules of a run do not already set the whole spread of weights (with 0, a
  // millijoule's difference between new tires gives the same weights as a tread's).
  double wear_offset = 0.0;
  // Bounds on a weight: a new tire's wear still costs something, a worn one's not everything.
  double min_weight = 0.25;
  double max_weight = 4.0;
  static const OptionFields<WearBalancingOptions>& fields();
  void validate() const;  // throws ConfigError naming the field and value
};

// The n weights for accumulated wear `wear` (n entries, finite and >= 0) on modules carrying
// `load_shares` of the static load (n entries, > 0, summing to 1): ((W_i + offset) / (W_bar +
// offset))^exponent scaled so their load-weighted mean is 1, then held within [min_weight,
// max_weight] (so the mean may then differ from 1); all 1 while W_bar + offset is 0 (new tires),
// and where a weight would not be finite. noexcept, no allocation.
void wear_balancing_weights(const WearBalancingOptions& options, const double* wear,
                            const double* load_shares, int n, double* weights) noexcept;

}  // namespace swerve
