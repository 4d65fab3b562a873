// Decides whether this cycle's measured state is fresh enough to control on. A measurement is stale
// when its timestamp is older than the latency compensation can roll forward, or when it repeats
// bit for bit for `frozen_cycles` cycles while the vehicle moves or has been commanded to move for
// longer than the measurement's age (a real sensor never repeats exactly then: a frozen driver, a
// dropped bus, a stuck estimator). Stale measurements end in a safe stop, which ends with them.
#pragma once

#include <Eigen/Core>

#include "swerve/core/option_fields.hpp"

namespace swerve {

struct StalenessOptions {
  // s: a measurement older than this (t - measured_at) is stale. 0 (the default): the latency the
  // compensation rolls forward, LatencyCompensator::kMaxSteps control periods (0.4 s at 20 Hz,
  // 0.16 s at 50 Hz), so a latency the controller can act on is never refused. See
  // docs/decisions/staleness.md.
  double max_age = 0.0;
  int frozen_cycles = 3;     // identical measurements in a row, while moving, that make it stale
  double moving_speed = 0.01;  // m/s (and rad/s of yaw): motion above which a repeat is suspect
  // The age limit at control period `period`: max_age, or the compensation's reach when it is 0.
  double max_age_at(double period) const noexcept;
  static const OptionFields<StalenessOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;     // throws ConfigError naming the field and value
};

class MeasurementMonitor {
 public:
  // `period`: the control period (s, > 0), which sets the default age limit.
  MeasurementMonitor(int state_size, StalenessOptions options, double period);

  // nullptr when the measurement may be used, else why not (static text). `motion_commanded_since`:
  // the time from which every command sent asked some module to move (+inf: the last one did not).
  // A repeat counts as frozen only when the measurement shows motion, or when motion had been
  // commanded for a whole period before it was taken; a repeat of the same timestamp is a resend,
  // which the age limit judges. Sizes are the caller's to check. noexcept, allocation-free.
  const char* check(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double measured_at,
                    double motion_commanded_since) noexcept;
  void reset() noexcept;
  const StalenessOptions& options() const noexcept { return options_; }
  double max_age() const noexcept { return max_age_; }  // s: the limit in force

  // s: ages within this of the limit are not stale. Timestamps are differences of doubles a few
  // ulps off (a 0.1 s latency measured as 0.10000000000000142 s); a microsecond is far below any
  // sensor's timing resolution and far above that round-off for any run shorter than a decade.
  static constexpr double kAgeTolerance = 1e-6;

 private:
  StalenessOptions options_;
  double period_;
  double max_age_;
  Eigen::VectorXd previous_;
  double previous_measured_at_ = 0.0;
  bool have_previous_ = false;
  int repeats_ = 0;  // consecutive cycles the measurement repeated while moving
};

}  // namespace swerve
