#include "swerve/control/measurement_monitor.hpp"

#include <cmath>

#include "swerve/control/latency_compensator.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {

const OptionFields<StalenessOptions>& StalenessOptions::fields() {
  static const OptionFields<StalenessOptions> table{
      {"max_age", &StalenessOptions::max_age, Bound::at_least(0.0), {}, nullptr,
       "(s; 0: the latency compensation's reach, 8 control periods)"},
      {"frozen_cycles", &StalenessOptions::frozen_cycles, Bound::closed(2, 1000000)},
      {"moving_speed", &StalenessOptions::moving_speed, Bound::positive()},
  };
  return table;
}

void StalenessOptions::validate() const { check_fields("StalenessOptions", *this, fields()); }

double StalenessOptions::max_age_at(double period) const noexcept {
  return max_age > 0.0 ? max_age : LatencyCompensator::kMaxSteps * period;
}

MeasurementMonitor::MeasurementMonitor(int state_size, StalenessOptions options, double period)
    : options_(options), period_(period) {
  options_.validate();
  if (!(period > 0.0) || !std::isfinite(period)) throw_invalid_field("MeasurementMonitor", "period", period, "must be > 0 and finite (s)");
  max_age_ = options_.max_age_at(period_);
  previous_ = Eigen::VectorXd::Zero(state_size);
}

void MeasurementMonitor::reset() noexcept {
  have_previous_ = false;
  repeats_ = 0;
}

const char* MeasurementMonitor::check(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double measured_at,
                                      double motion_commanded_since) noexcept {
  if (!std::isfinite(measured_at) || measured_at > t + kAgeTolerance) {
    return "measurement timestamp is not finite or lies in the future";
  }
  // A repeat is suspect only if it claims to be new (its timestamp moved on) while the vehicle
  // moves, or after it had been told to move for a whole period before the measurement was taken:
  // a vehicle the controller stopped, or one only just told to start, repeats exactly when the
  // sensor is noiseless, and that is no fault.
  const bool repeated = have_previous_ && measured.size() == previous_.size() && measured_at > previous_measured_at_ &&
                        measured == previous_;
  const bool moving = measured.size() >= 6 && (measured.segment<2>(3).norm() > options_.moving_speed ||
                                               std::abs(measured[5]) > options_.moving_speed);
  const bool told_to_move = motion_commanded_since + period_ <= measured_at + kAgeTolerance;
  if (measured_at > previous_measured_at_ || !have_previous_) {
    repeats_ = repeated && (moving || told_to_move) ? repeats_ + 1 : 0;
  }
  if (measured.size() == previous_.size()) {
    previous_ = measured;
    previous_measured_at_ = measured_at;
    have_previous_ = true;
  }
  if (t - measured_at > max_age_ + kAgeTolerance) return "measurement stale: older than stale_measurement.max_age";
  // repeats_ counts repeats, so frozen_cycles identical measurements are frozen_cycles - 1 repeats.
  if (repeats_ >= options_.frozen_cycles - 1) {
    return "measurement stale: identical for stale_measurement.frozen_cycles cycles while moving";
  }
  return nullptr;
}

}  // namespace swerve
