#include "swerve/control/actuator_estimator.hpp"

#include "swerve/kinematics/module_commands.hpp"
#include "swerve/models/drive_response.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {

double rolling_wheel_speed(const ModuleLayout& layout, const Eigen::Ref<const Eigen::VectorXd>& state,
                           int module) noexcept {
  const Eigen::Vector3d twist = state.segment<3>(StateIndex::kVx);
  const Eigen::Vector2d v_contact = point_velocity<double>(twist, layout.position_body(module));
  return rolling_speed<double>(v_contact, state[StateIndex::steering(module)]) / layout.wheel_radius();
}

ActuatorEstimator::ActuatorEstimator(const VehicleParams& vehicle, bool wheel_speeds, bool steering_rates)
    : layout_(vehicle.layout) {
  const int modules = layout_.size();
  if (wheel_speeds) {
    drive_time_constant_ = vehicle.actuators.drive_time_constant;
    if (vehicle.plant.actuator_saturation) {
      max_wheel_acceleration_ = layout_.limits().max_drive_acceleration / layout_.wheel_radius();
    }
    wheel_speeds_ = sent_wheel_speeds_ = Eigen::VectorXd::Zero(modules);
  }
  if (steering_rates) {
    steering_time_constant_ = vehicle.actuators.steering_time_constant;
    steering_rates_ = sent_steering_rates_ = Eigen::VectorXd::Zero(modules);
  }
}

void ActuatorEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& measured, double t, double max_gap) noexcept {
  const double elapsed = t - time_;
  double mean = 0.0;
  if (known_ && elapsed > 0.0 && elapsed <= max_gap) {
    // The time since the last commands were sent, through the drives' lag and clamp.
    const DriveLag lag{drive_time_constant_, max_wheel_acceleration_};
    for (Eigen::Index i = 0; i < wheel_speeds_.size(); ++i) {
      drive_response(wheel_speeds_[i], sent_wheel_speeds_[i], lag, elapsed, &wheel_speeds_[i], &mean);
    }
    const DriveLag steering_lag{steering_time_constant_, std::numeric_limits<double>::infinity()};
    for (Eigen::Index i = 0; i < steering_rates_.size(); ++i) {
      drive_response(steering_rates_[i], sent_steering_rates_[i], steering_lag, elapsed, &steering_rates_[i], &mean);
    }
  } else {
    for (Eigen::Index i = 0; i < wheel_speeds_.size(); ++i) {
      wheel_speeds_[i] = rolling_wheel_speed(layout_, measured, static_cast<int>(i));
    }
    steering_rates_.setZero();
  }
  time_ = t;
  estimated_ = true;
}

void ActuatorEstimator::record_sent(const ModuleArray<ModuleCommand>& commands) noexcept {
  if (!active()) return;
  for (Eigen::Index i = 0; i < wheel_speeds_.size(); ++i) sent_wheel_speeds_[i] = commands[static_cast<int>(i)].wheel_speed;
  for (Eigen::Index i = 0; i < steering_rates_.size(); ++i) {
    sent_steering_rates_[i] = commands[static_cast<int>(i)].steering_rate;
  }
  known_ = estimated_;
}

}  // namespace swerve
