#include "swerve/control/lost_steering_angles.hpp"

#include <algorithm>
#include <cmath>

#include "swerve/core/config_error.hpp"

namespace swerve {

LostSteeringAngles::LostSteeringAngles(const ModuleLayout& layout, double control_period)
    : limits_(layout.limits()), modules_(layout.size()), period_(control_period) {
  if (!std::isfinite(control_period) || control_period <= 0.0) {
    throw_invalid_field("LostSteeringAngles", "control_period", control_period, "must be > 0 (s)");
  }
  repaired_ = Eigen::VectorXd::Zero(6 + modules_);
}

void LostSteeringAngles::reset() noexcept {
  rates_.clear();
  known_.fill(false);
  lost_.fill(false);
}

void LostSteeringAngles::commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept {
  record_steering_rates(commands, t, modules_, &rates_);
}

double LostSteeringAngles::turn_commanded(int module, double from, double to) const noexcept {
  // Each command acts from its time until the next one's (the newest until `to`); before the
  // oldest kept nothing is known, and nothing turned.
  double turn = 0.0, until = to;
  for (int k = 0; k < rates_.size() && until > from; ++k) {
    const StampedModuleValues& sent = rates_.back(k);
    const double start = std::max(sent.t, from);
    if (until > start) turn += sent.values[static_cast<std::size_t>(module)] * (until - start);
    until = std::min(until, sent.t);
  }
  return turn;
}

bool LostSteeringAngles::repair(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at) noexcept {
  if (measured.size() != 6 + modules_ || !measured.head<6>().allFinite() || !std::isfinite(measured_at)) return false;
  bool any_lost = false;
  for (int i = 0; i < modules_; ++i) {
    const auto m = static_cast<std::size_t>(i);
    lost_[m] = !std::isfinite(measured[6 + i]);
    if (lost_[m] && (!known_[m] || measured_at < angles_at_)) {
      lost_.fill(false);
      return false;  // nothing to stand in with
    }
    any_lost = any_lost || lost_[m];
  }
  if (!any_lost) {  // every angle read: they are what a later stand-in starts from
    for (int i = 0; i < modules_; ++i) angles_[static_cast<std::size_t>(i)] = measured[6 + i];
    known_.fill(true);
    angles_at_ = measured_at;
    return false;
  }
  repaired_ = measured;
  for (int i = 0; i < modules_; ++i) {
    const auto m = static_cast<std::size_t>(i);
    if (lost_[m]) {
      double angle = angles_[m] + turn_commanded(i, angles_at_, measured_at);
      // Within the end stops, where the module stops turning; without any, unwrapped as measured.
      if (limits_.has_steering_end_stops()) angle = std::clamp(angle, limits_.min_steering_angle, limits_.max_steering_angle);
      repaired_[6 + i] = angle;
    }
    angles_[m] = repaired_[6 + i];
    known_[m] = true;
  }
  angles_at_ = measured_at;
  return any_lost;
}

}  // namespace swerve
