// Decides whether this cycle's measured state is fresh enough to control on. A measurement is stale
// when its timestamp is older than `max_age`, or when it repeats bit for bit for `frozen_cycles`
// cycles while the vehicle moves or is commanded to (a real sensor never repeats exactly then: a
// frozen driver, a dropped bus, a stuck estimator). Stale measurements end in a safe stop.
#pragma once

#include <Eigen/Core>

#include "swerve/core/option_fields.hpp"

namespace swerve {

struct StalenessOptions {
  double max_age = 0.1;      // s: t - measured_at beyond this is stale (two 20 Hz periods)
  int frozen_cycles = 3;     // identical measurements in a row, while moving, that make it stale
  double moving_speed = 0.01;  // m/s (and rad/s of yaw): motion above which a repeat is suspect
  static const OptionFields<StalenessOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;     // throws ConfigError naming the field and value
};

class MeasurementMonitor {
 public:
  MeasurementMonitor(int state_size, StalenessOptions options);

  // nullptr when the measurement may be used, else why not (static text). `motion_commanded`:
  // the last command sent asks some module to move. Sizes are the caller's to check. noexcept,
  // allocation-free.
  const char* check(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double measured_at,
                    bool motion_commanded) noexcept;
  void reset() noexcept;
  const StalenessOptions& options() const noexcept { return options_; }

 private:
  StalenessOptions options_;
  Eigen::VectorXd previous_;
  bool have_previous_ = false;
  int repeats_ = 0;  // consecutive cycles the measurement repeated while moving
};

}  // namespace swerve
