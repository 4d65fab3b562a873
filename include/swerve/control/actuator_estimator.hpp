// The drives' wheel speeds and the steering rates that a prediction with actuator lags starts from
// (PredictionOptions::drive_lag, steering_lag): the commands the controller sent, followed through
// the same first-order lags (and the drives' acceleration clamp) over the time since; or, with no
// command of ours to follow, the wheels rolling with the measured body and the steering at rest.
// Allocation-free after construction.
#pragma once

#include <Eigen/Core>

#include <limits>

#include "swerve/kinematics/module_state.hpp"
#include "swerve/models/vehicle_params.hpp"

namespace swerve {

// rad/s: module `module`'s wheel rolling with the body twist of `state` (x, y, psi, vx, vy, r,
// steering angles...) at its steering angle there.
double rolling_wheel_speed(const ModuleLayout& layout, const Eigen::Ref<const Eigen::VectorXd>& state,
                           int module) noexcept;

class ActuatorEstimator {
 public:
  // Estimates the wheel speeds when `wheel_speeds`, the steering rates when `steering_rates` (what
  // the prediction carries), with the vehicle's lags and, on a plant that saturates, its clamp.
  ActuatorEstimator(const VehicleParams& vehicle, bool wheel_speeds, bool steering_rates);

  // Whether there is anything to estimate.
  bool active() const noexcept { return wheel_speeds_.size() > 0 || steering_rates_.size() > 0; }

  // A step begins: its commands will be followed only if it estimates (estimate()) before it sends.
  void begin_step() noexcept { estimated_ = false; }
  // The estimates at t: the last commands followed through the lags when they were recorded at
  // most `max_gap` s before t; otherwise (start, forget(), time that went back or jumped) rolling
  // with `measured` and the steering at rest.
  void estimate(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double max_gap) noexcept;
  // The commands this step sent, followed from the next estimate on if this step estimated.
  void record_sent(const ModuleArray<ModuleCommand>& commands) noexcept;
  // No command of ours to follow any more (a reset).
  void forget() noexcept { known_ = false; }

  const Eigen::VectorXd& wheel_speeds() const noexcept { return wheel_speeds_; }      // n, or empty
  const Eigen::VectorXd& steering_rates() const noexcept { return steering_rates_; }  // n, or empty

 private:
  ModuleLayout layout_;
  Eigen::VectorXd wheel_speeds_, sent_wheel_speeds_;      // n (empty without drive_lag)
  Eigen::VectorXd steering_rates_, sent_steering_rates_;  // n (empty without steering_lag)
  double drive_time_constant_ = 0.0;                      // s
  double steering_time_constant_ = 0.0;                   // s
  double max_wheel_acceleration_ = std::numeric_limits<double>::infinity();  // rad/s^2
  double time_ = 0.0;      // s: the t the estimates are for
  bool known_ = false;     // whether the estimates continue from commands of ours
  bool estimated_ = false;  // this step estimated them (else the chain restarts)
};

}  // namespace swerve
