#include "swerve/control/latency_compensator.hpp"

#include <algorithm>
#include <cmath>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_commands.hpp"
#include "swerve/models/drive_response.hpp"

namespace swerve {

const OptionFields<MeasurementFilterOptions>& MeasurementFilterOptions::fields() {
  static const OptionFields<MeasurementFilterOptions> table{
      {"pose_gain", &MeasurementFilterOptions::pose_gain, Bound::half_open(0.0, 1.0)},
      {"steering_gain", &MeasurementFilterOptions::steering_gain, Bound::half_open(0.0, 1.0)},
  };
  return table;
}

void MeasurementFilterOptions::validate() const { check_fields("MeasurementFilterOptions", *this, fields()); }

ActuatorLags ActuatorLags::of(const VehicleParams& vehicle) noexcept {
  ActuatorLags lags;
  if (vehicle.plant.actuator_lag) {
    lags.steering = vehicle.actuators.steering_time_constant;
    lags.drive = vehicle.actuators.drive_time_constant;
  }
  return lags;
}

LatencyCompensator::LatencyCompensator(const ModuleLayout& layout, double dt, MeasurementFilterOptions filter,
                                       ActuatorLags lags)
    : kinematics_(layout), dt_(dt), lags_(lags), modules_(layout.size()), states_(layout.size()), filter_(filter) {
  if (!std::isfinite(dt) || dt <= 0.0) throw_invalid_field("LatencyCompensator", "dt", dt, "must be finite and > 0");
  if (!std::isfinite(lags.steering) || lags.steering < 0.0) {
    throw_invalid_field("LatencyCompensator", "lags.steering", lags.steering, "must be finite and >= 0 (s)");
  }
  if (!std::isfinite(lags.drive) || lags.drive < 0.0) {
    throw_invalid_field("LatencyCompensator", "lags.drive", lags.drive, "must be finite and >= 0 (s)");
  }
  filter_.validate();
  steering_rates_ = wheel_surface_speeds_ = Eigen::VectorXd::Zero(modules_);
  history_ = Eigen::MatrixXd::Zero(2 * modules_, kMaxSteps);
  filtered_ = predicted_ = Eigen::VectorXd::Zero(6 + modules_);
}

void LatencyCompensator::record(const ModuleArray<ModuleCommand>& commands) noexcept {
  newest_ = (newest_ + 1) % kMaxSteps;
  const double radius = kinematics_.layout().wheel_radius();
  for (int i = 0; i < modules_ && i < commands.size(); ++i) {
    history_(2 * i, newest_) = commands[i].steering_rate;
    history_(2 * i + 1, newest_) = radius * commands[i].wheel_speed;
  }
  recorded_ = std::min(recorded_ + 1, kMaxSteps);
}

int LatencyCompensator::latency_steps(double latency) const noexcept {
  if (!(latency > 0.5 * dt_)) return 0;
  return std::min({static_cast<int>(std::lround(std::min(latency / dt_, 1e3))), recorded_, kMaxSteps});
}

void LatencyCompensator::advance(Eigen::Ref<Eigen::VectorXd> state, int column) noexcept {
  for (int i = 0; i < modules_; ++i) {
    const double angle = state[6 + i];
    const double rate_command = history_(2 * i, column);
    const double speed_command = history_(2 * i + 1, column);
    // Through the lags: the angle moves by the mean steering rate over the period.
    double mean_rate = rate_command, mean_speed = speed_command;
    follow_lag(lags_.steering, rate_command, &steering_rates_[i], &mean_rate);
    follow_lag(lags_.drive, speed_command, &wheel_surface_speeds_[i], &mean_speed);
    state[6 + i] = wrap_angle(angle + dt_ * mean_rate);
    // The module drives along its mean angle over the period (midpoint rule).
    states_[i].angle = wrap_angle(angle + 0.5 * dt_ * mean_rate);
    states_[i].speed = mean_speed;
  }
  Eigen::Vector3d twist_body = Eigen::Vector3d::Zero();
  if (kinematics_.forward(states_, &twist_body) != KinematicsStatus::kOk) twist_body.setZero();
  const double heading = state[2] + 0.5 * dt_ * twist_body.z();
  const double c = std::cos(heading), s = std::sin(heading);
  state[0] += dt_ * (c * twist_body.x() - s * twist_body.y());
  state[1] += dt_ * (s * twist_body.x() + c * twist_body.y());
  state[2] += dt_ * twist_body.z();  // headings stay continuous, as measured
  // The twist the drives reach at the period's end is a better guess than a delayed one (without
  // lags, the commanded one).
  state.segment<3>(3) = twist_body;
  if (!(lags_.steering > 0.0) && !(lags_.drive > 0.0)) return;
  for (int i = 0; i < modules_; ++i) {
    states_[i].angle = wrap_angle(state[6 + i]);
    states_[i].speed = wheel_surface_speeds_[i];
  }
  if (kinematics_.forward(states_, &twist_body) == KinematicsStatus::kOk) state.segment<3>(3) = twist_body;
}

void LatencyCompensator::follow_lag(double time_constant, double command, double* state, double* mean) noexcept {
  if (!(time_constant > 0.0)) {  // a drive that reaches its command at once
    *state = *mean = command;
    return;
  }
  DriveLag lag;
  lag.time_constant = time_constant;
  double end = 0.0;
  drive_response<double>(*state, command, lag, dt_, &end, mean);
  *state = end;
}

void LatencyCompensator::start_drives(const Eigen::Ref<const Eigen::VectorXd>& measured, int latency) noexcept {
  // Steering rates: from rest at the oldest recorded command, through those sent before the
  // measurement was taken (each lag forgets its start within a few periods).
  steering_rates_.setZero();
  for (int back = recorded_ - 1; back >= latency; --back) {
    const int column = (newest_ - back + kMaxSteps) % kMaxSteps;
    double mean = 0.0;
    for (int i = 0; i < modules_; ++i) follow_lag(lags_.steering, history_(2 * i, column), &steering_rates_[i], &mean);
  }
  // Wheels: rolling with the measured twist at their measured angles (the measurement knows them).
  const Eigen::Vector3d twist_body = measured.segment<3>(3);
  for (int i = 0; i < modules_; ++i) {
    const Eigen::Vector2d v_contact = point_velocity<double>(twist_body, kinematics_.layout().position_body(i));
    wheel_surface_speeds_[i] = rolling_speed<double>(v_contact, measured[6 + i]);
  }
}

int LatencyCompensator::compensate(const Eigen::Ref<const Eigen::VectorXd>& measured, double latency,
                                   Eigen::Ref<Eigen::VectorXd> now) noexcept {
  now = measured;
  if (measured.size() != 6 + modules_ || now.size() != measured.size()) return 0;
  const int steps = latency_steps(latency);
  start_drives(measured, steps);
  // The commands sent since the measurement, oldest first: the measured state saw none of them.
  for (int back = steps - 1; back >= 0; --back) advance(now, (newest_ - back + kMaxSteps) % kMaxSteps);
  return steps;
}

bool LatencyCompensator::update_filter(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at,
                                       int latency) noexcept {
  if (!filtered_valid_) return false;
  const double periods_since = (measured_at - filtered_at_) / dt_;
  if (!(std::abs(periods_since) < 1e3)) return false;
  const int periods = static_cast<int>(std::lround(periods_since));
  if (periods == 0) return true;  // the same measurement again: nothing new to blend
  if (periods < 0 || latency + periods > std::min(recorded_, kMaxSteps)) return false;
  // The estimate, predicted by the commands that acted from its time to the measurement's.
  predicted_ = filtered_;
  start_drives(filtered_, latency + periods);
  for (int back = latency + periods - 1; back >= latency; --back) {
    advance(predicted_, (newest_ - back + kMaxSteps) % kMaxSteps);
  }
  const Eigen::Vector2d position_surprise = measured.head<2>() - predicted_.head<2>();
  const double heading_surprise = wrap_angle(measured[2] - predicted_[2]);
  if (position_surprise.norm() > MeasurementFilterOptions::kResetDistance ||
      std::abs(heading_surprise) > MeasurementFilterOptions::kResetAngle) {
    return false;
  }
  for (int i = 0; i < modules_; ++i) {
    if (std::abs(wrap_angle(measured[6 + i] - predicted_[6 + i])) > MeasurementFilterOptions::kResetAngle) return false;
  }
  filtered_.head<2>() = predicted_.head<2>() + filter_.pose_gain * position_surprise;
  filtered_[2] = predicted_[2] + filter_.pose_gain * heading_surprise;
  filtered_.segment<3>(3) = measured.segment<3>(3);
  for (int i = 0; i < modules_; ++i) {
    filtered_[6 + i] =
        wrap_angle(predicted_[6 + i] + filter_.steering_gain * wrap_angle(measured[6 + i] - predicted_[6 + i]));
  }
  filtered_at_ = measured_at;
  return true;
}

int LatencyCompensator::estimate(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at, double t,
                                 Eigen::Ref<Eigen::VectorXd> now) noexcept {
  const double taken = std::isfinite(measured_at) ? measured_at : t;
  const double latency = t - taken;
  if (!filter_.filters() || measured.size() != 6 + modules_) return compensate(measured, latency, now);
  if (!update_filter(measured, taken, latency_steps(latency))) {
    filtered_ = measured;
    filtered_at_ = taken;
    filtered_valid_ = true;
  }
  return compensate(filtered_, latency, now);
}

}  // namespace swerve
