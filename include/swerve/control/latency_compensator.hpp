// Rolls a delayed measurement forward to the time it is acted on (a Smith predictor on the
// kinematic model): the steering angles advance by the steering rates commanded since the
// measurement was taken, the pose by the body twist those commands make (forward kinematics).
// Both controllers use it, so a measurement latency the timestamp reveals never meets a deadbeat
// steering law that reacts to its own delayed effect. Optionally it is also a fixed-gain observer: the
// same prediction, blended with each new measurement, filters sensor noise.
#pragma once

#include <Eigen/Core>

#include "swerve/core/option_fields.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/models/vehicle_params.hpp"
#include "swerve/control/tracking_controller.hpp"

namespace swerve {

// The observer's gains: the share of a new measurement's surprise (measured - predicted) taken into
// the estimate each period, a steady-state Kalman gain of the kinematic model. 1 takes every
// measurement as it is (no filtering, the default); smaller gains trust the commands more. For
// white noise the estimate's standard deviation is sqrt(g / (2 - g)) of the sensor's.
struct MeasurementFilterOptions {
  double pose_gain = 1.0;      // x, y and heading
  double steering_gain = 1.0;  // module steering angles
  // A surprise beyond these is a jump (relocalisation, a module turned by hand), not noise: the
  // estimate restarts from the measurement.
  static constexpr double kResetDistance = 0.5;  // m
  static constexpr double kResetAngle = 0.5;     // rad
  bool filters() const noexcept { return pose_gain < 1.0 || steering_gain < 1.0; }
  static const OptionFields<MeasurementFilterOptions>& fields();  // the rules, read by the YAML loader too
  void validate() const;  // gains in (0, 1]; throws ConfigError naming the field and value
};

// The first-order lags (s) through which the drives follow their commands: the steering rate and
// the wheel speed. 0: a drive that reaches its command at once.
struct ActuatorLags {
  double steering = 0.0;
  double drive = 0.0;
  // The vehicle's own (ActuatorParams), or none when its drives follow at once (plant.actuator_lag off).
  static ActuatorLags of(const VehicleParams& vehicle) noexcept;
};

class LatencyCompensator {
 public:
  // Longest latency rolled forward, in control periods; an older measurement is rolled forward by
  // this many (the wear-aware controller rejects one older than its staleness bound first).
  static constexpr int kMaxSteps = 8;

  // With `lags`, the commands are rolled forward through the drives' lags, from the steering rates
  // and wheel speeds they had when the measurement was taken (estimated from the commands before
  // it, and from the measured twist): a steering command that the lag has not yet carried out does
  // not move the estimated angle. Without them, a 0.8 rad/s command moved the estimated angle by
  // 0.04 rad in a period where the 30 ms lag moved the wheel by 0.007 rad, and the controller
  // answered the difference it had made up with the opposite command: a period-2 limit cycle.
  LatencyCompensator(const ModuleLayout& layout, double dt, MeasurementFilterOptions filter = {},
                     ActuatorLags lags = {});

  // Remembers the commands sent this cycle (call once per step, after deciding them).
  void record(const ModuleArray<ModuleCommand>& commands) noexcept;
  // Forgets every recorded command and the filtered estimate (after a reset or a safe stop whose
  // effect is unknown).
  void reset() noexcept {
    recorded_ = 0;
    filtered_valid_ = false;
  }

  // Writes into `now` the measured state (pose, twist, steering angles: 6 + n) rolled forward by
  // `latency` seconds, rounded to whole periods and at most kMaxSteps or the commands recorded.
  // With no latency `now` is the measurement, bit for bit. Returns the periods rolled forward.
  int compensate(const Eigen::Ref<const Eigen::VectorXd>& measured, double latency,
                 Eigen::Ref<Eigen::VectorXd> now) noexcept;

  // What the controllers call each period: the measurement taken at `measured_at` (non-finite:
  // at t) filtered by the observer, when its gains are below 1, then rolled forward to t as
  // compensate() does. The observer predicts its last estimate by the commands that acted until
  // `measured_at` and moves it by the gains toward the measurement. A measurement that repeats the
  // last one's time adds nothing; one it cannot align with the recorded commands, or a jump beyond
  // the reset bounds, restarts the estimate from the measurement. Returns the periods rolled forward.
  int estimate(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at, double t,
               Eigen::Ref<Eigen::VectorXd> now) noexcept;

 private:
  // Advances `state` (6 + n) by one period of the recorded command in history column `column`,
  // through the lags from the drives' state in steering_rates_ and wheel_surface_speeds_ (which it
  // advances too).
  void advance(Eigen::Ref<Eigen::VectorXd> state, int column) noexcept;
  // Sets steering_rates_ and wheel_surface_speeds_ to their estimate when `measured` was taken,
  // `latency` periods of recorded commands ago: the steering rates through the commands before
  // then (from rest at the oldest recorded), the wheels rolling with the measured twist.
  void start_drives(const Eigen::Ref<const Eigen::VectorXd>& measured, int latency) noexcept;
  // One period of a drive following `command` through a first-order lag of `time_constant` (0: at
  // once), from *state: its state at the end in *state, its mean over the period in *mean
  // (drive_response, the prediction's own law).
  void follow_lag(double time_constant, double command, double* state, double* mean) noexcept;
  int latency_steps(double latency) const noexcept;
  // The observer's update; false when the estimate must restart from the measurement.
  bool update_filter(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at, int latency) noexcept;

  Kinematics kinematics_;
  double dt_;
  ActuatorLags lags_;
  Eigen::VectorXd steering_rates_, wheel_surface_speeds_;  // n: the drives' estimated state
  int modules_;
  Eigen::MatrixXd history_;  // 2n x kMaxSteps ring: steering rate, wheel surface speed per module
  int newest_ = -1, recorded_ = 0;
  ModuleStates states_;
  MeasurementFilterOptions filter_;
  Eigen::VectorXd filtered_, predicted_;  // 6 + n: the estimate at filtered_at_, its prediction
  double filtered_at_ = 0.0;
  bool filtered_valid_ = false;
};

}  // namespace swerve
