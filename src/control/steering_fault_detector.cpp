#include "swerve/control/steering_fault_detector.hpp"

#include <algorithm>
#include <cmath>

#include "swerve/core/config_error.hpp"

namespace swerve {

const OptionFields<FaultDetectionOptions>& FaultDetectionOptions::fields() {
  // Direct-list-initialised: with `= {` and a bool field GCC 12 stops with an internal error.
  static const OptionFields<FaultDetectionOptions> table{
      {"enabled", &FaultDetectionOptions::enabled},
      {"min_commanded_turn",
       &FaultDetectionOptions::min_commanded_turn,
       Bound::positive(),
       {},
       nullptr,
       "(rad)"},
      {"max_followed_share", &FaultDetectionOptions::max_followed_share, Bound::open(0.0, 1.0)},
      {"window_cycles", &FaultDetectionOptions::window_cycles, Bound::closed(1, 60)},
      {"confirm_cycles", &FaultDetectionOptions::confirm_cycles, Bound::closed(1, 60)},
  };
  return table;
}

void FaultDetectionOptions::validate() const { check_fields("FaultDetectionOptions", *this, fields()); }

SteeringFaultDetector::SteeringFaultDetector(const ModuleLayout& layout, double control_period,
                                             double steering_lag, FaultDetectionOptions options)
    : options_(options),
      limits_(layout.limits()),
      modules_(layout.size()),
      period_(control_period),
      steering_lag_(steering_lag) {
  options_.validate();
  if (!std::isfinite(control_period) || control_period <= 0.0) {
    throw_invalid_field("SteeringFaultDetector", "control_period", control_period, "must be > 0");
  }
  if (!std::isfinite(steering_lag) || steering_lag < 0.0) {
    throw_invalid_field("SteeringFaultDetector", "steering_lag", steering_lag, "must be >= 0 (s)");
  }
  if (modules_ < 1 || modules_ > kMaxModules) {
    throw_invalid_field("SteeringFaultDetector", "modules", modules_, "must be in [1, 16]");
  }
  // Long enough that a module turning at half its rate limit is asked min_commanded_turn: on a
  // 1 rad/s carrier at 20 Hz, 3 periods could never ask 0.2 rad. The steering's lag needs no
  // longer window: the commands are run through it (observe()).
  const double for_turn = 2.0 * options_.min_commanded_turn / (limits_.max_steering_rate * control_period);
  const double periods = std::max(static_cast<double>(options_.window_cycles), std::ceil(for_turn - 1e-9));
  if (periods > kHistory - 4) {
    throw_invalid_field("SteeringFaultDetector", "window", periods,
                        "periods exceed the history of " + std::to_string(kHistory - 4) +
                            " (min_commanded_turn far too large for this steering rate and control period)");
  }
  window_ = static_cast<int>(periods);
}

void SteeringFaultDetector::reset() noexcept {
  angles_.clear();
  rates_.clear();
  agreeing_.fill(0);
  stuck_.fill(false);
}

void SteeringFaultDetector::commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept {
  record_steering_rates(commands, t, modules_, &rates_);
}

bool SteeringFaultDetector::observe(const Eigen::Ref<const Eigen::VectorXd>& steering_angles,
                                    double measured_at) noexcept {
  if (steering_angles.size() != modules_ || !steering_angles.allFinite() || !std::isfinite(measured_at))
    return false;
  // A measurement no newer than the last (a frozen sensor) adds no window.
  if (!angles_.empty() && measured_at <= angles_.newest().t + 0.5 * period_) return false;
  StampedModuleValues& newest = angles_.push(measured_at);
  for (int i = 0; i < modules_; ++i) newest.values[static_cast<std::size_t>(i)] = steering_angles[i];
  if (!options_.enabled) return false;

  // The window [start, measured_at]: the angles at both ends, and the commands sent in it (each
  // acts over the period after it, through the steering's lag; max_followed_share allows for what
  // the lag model misses: noise, the rate limit, a lag not quite first order).
  const double start = measured_at - window_ * period_;
  const int first = angles_.find(start, 0.5 * period_);
  // A window with a gap is no window; the next whole one starts the agreement afresh.
  if (first < 0) {
    agreeing_.fill(0);
    return false;
  }
  // The turn the window's commands make through the steering's first-order rate lag, from the
  // rate the older commands left each drive at (the lag run from the oldest kept, at rest there:
  // the history is many lags long). A healthy steering falls behind the bare sum of its commands
  // by lag x (rate change over the window): a command that swings from -3.7 to +3.7 rad/s behind
  // a 92 ms lag asks 0.7 rad more than the module can have turned, and judged on the bare sum,
  // every module of such a vehicle was found stuck.
  std::array<double, kMaxModules> asked{}, rate{};
  const double decay = steering_lag_ > 0.0 ? std::exp(-period_ / steering_lag_) : 0.0;
  int periods = 0;
  for (int back = rates_.size() - 1; back >= 0; --back) {
    const StampedModuleValues& sample = rates_.back(back);
    if (sample.t >= measured_at - 0.5 * period_) break;
    const bool in_window = sample.t >= start - 0.5 * period_;
    periods += in_window ? 1 : 0;
    for (int i = 0; i < modules_; ++i) {
      const auto m = static_cast<std::size_t>(i);
      const double command = sample.values[m];
      // The exact integral of the lagged rate over the period, and its value at the period's end.
      if (in_window) asked[m] += command * period_ + (rate[m] - command) * steering_lag_ * (1.0 - decay);
      rate[m] = command + (rate[m] - command) * decay;
    }
  }
  // Judged only on a window every command of which is known (no gap in the history).
  if (periods != window_) {
    agreeing_.fill(0);
    return false;
  }
  const StampedModuleValues& before = angles_.back(first);
  const bool end_stops = limits_.has_steering_end_stops();
  bool found = false;
  for (int i = 0; i < modules_; ++i) {
    const auto m = static_cast<std::size_t>(i);
    if (stuck_[m]) continue;
    double turn = asked[m];
    // The end stops bound what a working steering can make of the commands.
    if (end_stops) {
      turn = std::clamp(turn, limits_.min_steering_angle - before.values[m],
                        limits_.max_steering_angle - before.values[m]);
    }
    const double moved =
        end_stops ? newest.values[m] - before.values[m] : wrap_angle(newest.values[m] - before.values[m]);
    const bool refused = std::abs(turn) >= options_.min_commanded_turn &&
                         moved * (turn > 0.0 ? 1.0 : -1.0) < options_.max_followed_share * std::abs(turn);
    agreeing_[m] = refused ? agreeing_[m] + 1 : 0;
    if (agreeing_[m] >= options_.confirm_cycles) {
      stuck_[m] = true;
      found = true;
    }
  }
  return found;
}

}  // namespace swerve
