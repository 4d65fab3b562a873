#include "swerve/control/measurement_monitor.hpp"

#include <cmath>

#include "swerve/core/config_error.hpp"

namespace swerve {

const OptionFields<StalenessOptions>& StalenessOptions::fields() {
  static const OptionFields<StalenessOptions> table{
      {"max_age", &StalenessOptions::max_age, Bound::positive()},
      {"frozen_cycles", &StalenessOptions::frozen_cycles, Bound::closed(2, 1000000)},
      {"moving_speed", &StalenessOptions::moving_speed, Bound::positive()},
  };
  return table;
}

void StalenessOptions::validate() const { check_fields("StalenessOptions", *this, fields()); }

MeasurementMonitor::MeasurementMonitor(int state_size, StalenessOptions options) : options_(options) {
  options_.validate();
  previous_ = Eigen::VectorXd::Zero(state_size);
}

void MeasurementMonitor::reset() noexcept {
  have_previous_ = false;
  repeats_ = 0;
}

const char* MeasurementMonitor::check(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double measured_at,
                                      bool motion_commanded) noexcept {
  if (!std::isfinite(measured_at) || measured_at > t + 1e-9) {
    return "measurement timestamp is not finite or lies in the future";
  }
  const bool repeated = have_previous_ && measured.size() == previous_.size() && measured == previous_;
  const bool moving = measured.size() >= 6 && (measured.segment<2>(3).norm() > options_.moving_speed ||
                                               std::abs(measured[5]) > options_.moving_speed);
  repeats_ = repeated && (moving || motion_commanded) ? repeats_ + 1 : 0;
  if (measured.size() == previous_.size()) {
    previous_ = measured;
    have_previous_ = true;
  }
  if (t - measured_at > options_.max_age) return "measurement stale: older than stale_measurement.max_age";
  // repeats_ counts repeats, so frozen_cycles identical measurements are frozen_cycles - 1 repeats.
  if (repeats_ >= options_.frozen_cycles - 1) {
    return "measurement stale: identical for stale_measurement.frozen_cycles cycles while moving";
  }
  return nullptr;
}

}  // namespace swerve
