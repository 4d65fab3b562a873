#include "swerve/mpc/latency_compensator.hpp"

#include <algorithm>
#include <cmath>

#include "swerve/config/config_error.hpp"

namespace swerve {

LatencyCompensator::LatencyCompensator(const ModuleLayout& layout, double dt)
    : kinematics_(layout), dt_(dt), modules_(layout.size()), states_(layout.size()) {
  if (!std::isfinite(dt) || dt <= 0.0) throw_invalid_field("LatencyCompensator", "dt", dt, "must be finite and > 0");
  history_ = Eigen::MatrixXd::Zero(2 * modules_, kMaxSteps);
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

int LatencyCompensator::compensate(const Eigen::Ref<const Eigen::VectorXd>& measured, double latency,
                                   Eigen::Ref<Eigen::VectorXd> now) noexcept {
  now = measured;
  if (!(latency > 0.5 * dt_) || measured.size() != 6 + modules_ || now.size() != measured.size()) return 0;
  const int steps = std::min({static_cast<int>(std::lround(std::min(latency / dt_, 1e3))), recorded_, kMaxSteps});
  // The commands sent since the measurement, oldest first: the measured state saw none of them.
  for (int back = steps - 1; back >= 0; --back) {
    const int column = (newest_ - back + kMaxSteps) % kMaxSteps;
    for (int i = 0; i < modules_; ++i) {
      const double angle = now[6 + i];
      now[6 + i] = wrap_angle(angle + dt_ * history_(2 * i, column));
      // The module drives along its mean angle over the period (midpoint rule).
      states_[i].angle = wrap_angle(angle + 0.5 * dt_ * history_(2 * i, column));
      states_[i].speed = history_(2 * i + 1, column);
    }
    Eigen::Vector3d twist_body = Eigen::Vector3d::Zero();
    if (kinematics_.forward(states_, &twist_body) != KinematicsStatus::kOk) twist_body.setZero();
    const double heading = now[2] + 0.5 * dt_ * twist_body.z();
    const double c = std::cos(heading), s = std::sin(heading);
    now[0] += dt_ * (c * twist_body.x() - s * twist_body.y());
    now[1] += dt_ * (s * twist_body.x() + c * twist_body.y());
    now[2] += dt_ * twist_body.z();  // headings stay continuous, as measured
    // The twist the drives are being told now is a better guess than the delayed one.
    if (back == 0) now.segment<3>(3) = twist_body;
  }
  return steps;
}

}  // namespace swerve
