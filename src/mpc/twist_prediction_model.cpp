#include "swerve/mpc/twist_prediction_model.hpp"

#include <algorithm>
#include <cmath>

namespace swerve {
namespace {

// Below this contact speed a module's direction is noise: it keeps its angle (the singularity hold).
constexpr double kHoldSpeed = 1e-3;  // m/s

}  // namespace

TwistPredictionModel::TwistPredictionModel(const VehicleParams& params, PredictionOptions options)
    : modules_(params, options), layout_(params.layout) {
  inputs_ = Eigen::VectorXd::Zero(modules_.input_size());
}

void TwistPredictionModel::module_inputs(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Vector3d& twist_body,
                                         double dt, Eigen::Ref<Eigen::VectorXd> inputs) const noexcept {
  const ModuleLimits& limits = layout_.limits();
  const bool end_stops = limits.has_steering_end_stops();
  const double max_wheel_speed = limits.max_drive_speed / layout_.wheel_radius();
  for (int i = 0; i < layout_.size(); ++i) {
    const Eigen::Vector2d& p = layout_.position_body(i);
    const double vx = twist_body.x() - twist_body.z() * p.y();
    const double vy = twist_body.y() + twist_body.z() * p.x();
    const double speed = std::hypot(vx, vy);
    const double angle = x[StateIndex::steering(i)];
    double rate = 0.0, wheel_speed = 0.0;
    if (speed > kHoldSpeed) {
      // Of the two ways to point the wheel along (vx, vy), the one nearer the current angle (the
      // 180 deg flip), unless it lies past an end stop.
      const double forward = std::atan2(vy, vx);
      double error = wrap_angle(forward - angle);
      double sign = 1.0;
      if (std::abs(error) > kPi / 2) {
        error = wrap_angle(error + kPi);
        sign = -1.0;
      }
      if (end_stops && (angle + error < limits.min_steering_angle || angle + error > limits.max_steering_angle)) {
        error = error > 0.0 ? error - kPi : error + kPi;
        sign = -sign;
      }
      rate = std::clamp(error / dt, -limits.max_steering_rate, limits.max_steering_rate);
      // Drive only as fast as the wheel points the right way at the end of this step.
      const double remaining = error - rate * dt;
      wheel_speed = std::clamp(sign * speed * std::max(0.0, std::cos(remaining)) / layout_.wheel_radius(),
                               -max_wheel_speed, max_wheel_speed);
    }
    inputs[InputIndex::steering_rate(i)] = rate;
    inputs[InputIndex::wheel_speed(i)] = wheel_speed;
  }
}

bool TwistPredictionModel::step(const Eigen::Ref<const Eigen::VectorXd>& x,
                                const Eigen::Ref<const Eigen::VectorXd>& twist_body, double dt,
                                Eigen::Ref<Eigen::VectorXd> x_next, double* stage_wear) const noexcept {
  if (x.size() != state_size() || twist_body.size() != 3 || !x.allFinite() || !twist_body.allFinite() || !(dt > 0.0)) {
    return false;
  }
  module_inputs(x, twist_body.head<3>(), dt, inputs_);
  return modules_.step(x, inputs_, dt, x_next, stage_wear);
}

}  // namespace swerve
