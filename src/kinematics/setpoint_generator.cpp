#include "swerve/kinematics/setpoint_generator.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "swerve/kinematics/module_commands.hpp"

namespace swerve {
namespace {

void require_positive(const char* field, double value) {
  if (!std::isfinite(value) || value <= 0.0) {
    std::ostringstream message;
    message << "ProfileLimits." << field << " = " << value << ": must be finite and > 0";
    throw ConfigError(message.str());
  }
}

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// Signed angle from heading h to the line of u, modulo pi, in (-pi/2, pi/2].
double line_angle_from(const Eigen::Vector2d& h, const Eigen::Vector2d& u) {
  double angle = std::atan2(cross(h, u), h.dot(u));
  if (angle > kPi / 2.0) angle -= kPi;
  if (angle <= -kPi / 2.0) angle += kPi;
  return angle;
}

bool finite_setpoint(const Setpoint& s) {
  if (!s.twist_body.allFinite()) return false;
  for (const ModuleState& m : s.modules) {
    if (!std::isfinite(m.speed) || !std::isfinite(m.angle)) return false;
  }
  for (double a : s.drive_acceleration) {
    if (!std::isfinite(a)) return false;
  }
  return true;
}

}  // namespace

ProfileLimits ProfileLimits::from_module_limits(const ModuleLimits& limits, double max_drive_jerk) {
  ProfileLimits profile;
  profile.max_drive_speed = limits.max_drive_speed;
  profile.max_drive_acceleration = limits.max_drive_acceleration;
  profile.max_steering_rate = limits.max_steering_rate;
  profile.max_drive_jerk = max_drive_jerk;
  return profile;
}

void ProfileLimits::validate() const {
  require_positive("max_drive_speed", max_drive_speed);
  require_positive("max_drive_acceleration", max_drive_acceleration);
  require_positive("max_steering_rate", max_steering_rate);
  if (!std::isfinite(max_drive_jerk) || max_drive_jerk < 0.0) {
    std::ostringstream message;
    message << "ProfileLimits.max_drive_jerk = " << max_drive_jerk << ": must be finite and >= 0 (0 = off)";
    throw ConfigError(message.str());
  }
}

SetpointGenerator::SetpointGenerator(Kinematics kinematics, ProfileLimits limits, ProfileMode mode)
    : kinematics_(std::move(kinematics)), limits_(limits), mode_(mode) {
  limits_.validate();
}

Setpoint SetpointGenerator::stopped(const ModuleStates* angles) const {
  const int n = kinematics_.size();
  Setpoint setpoint;
  setpoint.modules = ModuleStates(n);
  setpoint.drive_acceleration = ModuleArray<double>(n, 0.0);
  if (angles != nullptr) {
    if (angles->size() != n) {
      throw ConfigError("SetpointGenerator::stopped: angles size = " + std::to_string(angles->size()) +
                        ": must be " + std::to_string(n));
    }
    for (int i = 0; i < n; ++i) {
      if (!std::isfinite((*angles)[i].angle)) {
        throw ConfigError("SetpointGenerator::stopped: angles[" + std::to_string(i) + "]: must be finite");
      }
      setpoint.modules[i].angle = wrap_angle((*angles)[i].angle);
    }
  }
  return setpoint;
}

double SetpointGenerator::allowed_acceleration(double previous_acceleration, double remaining,
                                               double dt) const noexcept {
  double allowed = limits_.max_drive_acceleration;
  const double jerk = limits_.max_drive_jerk;
  if (jerk > 0.0) {
    // Rise at most at the jerk limit; fall so that the acceleration reaches 0 just as the speed
    // reaches its target (a = sqrt(2 j dv) is the jerk-limited braking curve of the acceleration).
    allowed = std::min({allowed, std::abs(previous_acceleration) + jerk * dt, std::sqrt(2.0 * jerk * remaining)});
  }
  return allowed;
}

KinematicsStatus SetpointGenerator::step(const Setpoint& previous, const Eigen::Vector3d& target_twist_body,
                                         double dt, Setpoint* next) const noexcept {
  const int n = kinematics_.size();
  KinematicsStatus status = KinematicsStatus::kOk;
  if (previous.modules.size() != n || previous.drive_acceleration.size() != n) {
    status = KinematicsStatus::kWrongModuleCount;
  } else if (!finite_setpoint(previous) || !target_twist_body.allFinite()) {
    status = KinematicsStatus::kNonFiniteInput;
  } else if (!std::isfinite(dt) || dt <= 0.0) {
    status = KinematicsStatus::kInvalidDt;
  }
  if (status != KinematicsStatus::kOk) {
    const int size = std::min(previous.modules.size(), n);
    next->twist_body.setZero();
    next->modules.resize(n);
    next->drive_acceleration.resize(n);
    for (int i = 0; i < n; ++i) {
      next->modules[i] = ModuleState{0.0, i < size && std::isfinite(previous.modules[i].angle)
                                              ? wrap_angle(previous.modules[i].angle)
                                              : 0.0};
      next->drive_acceleration[i] = 0.0;
    }
    return status;
  }
  Eigen::Vector3d target;
  kinematics_.desaturate_twist(target_twist_body, limits_.max_drive_speed, DesaturationPriority::kProportional,
                               &target);  // inputs checked above
  return mode_ == ProfileMode::kBodyFirst ? step_body_first(previous, target, dt, next)
                                          : step_module_first(previous, target, dt, next);
}

KinematicsStatus SetpointGenerator::step_body_first(const Setpoint& previous, const Eigen::Vector3d& target_in,
                                                    double dt, Setpoint* next) const noexcept {
  const int n = kinematics_.size();
  const double threshold = kinematics_.options().hold_speed_threshold;
  const double max_turn = limits_.max_steering_rate * dt;
  const double tan_turn = max_turn < kPi / 2.0 ? std::tan(max_turn) : 0.0;
  const bool turn_unlimited = max_turn >= kPi / 2.0;  // any line is reachable modulo pi
  const ModuleLayout& layout = kinematics_.layout();

  std::array<Eigen::Vector2d, kMaxModules> heading{}, u_prev{}, u_target{};
  std::array<double, kMaxModules> speed_prev{};
  Eigen::Vector3d target = target_in;
  bool any_counted = false;
  bool all_reverse = true;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double angle = previous.modules[i].angle;
    heading[k] = Eigen::Vector2d(std::cos(angle), std::sin(angle));
    u_prev[k] = point_velocity<double>(previous.twist_body, layout.position_body(i));
    u_target[k] = point_velocity<double>(target, layout.position_body(i));
    speed_prev[k] = heading[k].dot(u_prev[k]);
    if (u_prev[k].norm() >= threshold && u_target[k].norm() >= threshold) {
      any_counted = true;
      all_reverse = all_reverse && u_prev[k].dot(u_target[k]) < 0.0;
    }
  }
  if (any_counted && all_reverse) {  // stop-then-resteer: brake along the current headings first
    target.setZero();
    for (int i = 0; i < n; ++i) u_target[static_cast<std::size_t>(i)].setZero();
  }

  std::array<double, kMaxModules> allowed_change{};
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Eigen::Vector2d& u = u_target[k];
    const double target_speed = heading[k].dot(u) >= 0.0 ? u.norm() : -u.norm();
    allowed_change[k] = allowed_acceleration(previous.drive_acceleration[i], std::abs(target_speed - speed_prev[k]), dt) * dt;
  }
  auto feasible = [&](int i, double s) {
    const auto k = static_cast<std::size_t>(i);
    const Eigen::Vector2d u = u_prev[k] + s * (u_target[k] - u_prev[k]);
    const double along = heading[k].dot(u);
    const double speed = u.norm();
    double signed_speed = along;
    if (speed >= threshold) {
      if (!turn_unlimited && std::abs(cross(heading[k], u)) > tan_turn * std::abs(along)) return false;
      signed_speed = along >= 0.0 ? speed : -speed;
    }
    return std::abs(signed_speed - speed_prev[k]) <= allowed_change[k] * (1.0 + 1e-12) + 1e-15;
  };

  double scale = 1.0;
  for (int i = 0; i < n; ++i) {
    if (feasible(i, scale)) continue;
    if (!feasible(i, 0.0)) {
      scale = 0.0;
      break;
    }
    double lo = 0.0;
    double hi = scale;
    for (int iteration = 0; iteration < 30; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      (feasible(i, mid) ? lo : hi) = mid;
    }
    scale = lo;
  }
  // Per-module feasible sets need not be intervals; shrink until every module agrees.
  for (int attempt = 0; attempt < 30 && scale > 0.0; ++attempt) {
    bool all_feasible = true;
    for (int i = 0; i < n && all_feasible; ++i) all_feasible = feasible(i, scale);
    if (all_feasible) break;
    scale *= 0.5;
  }

  next->twist_body = previous.twist_body + scale * (target - previous.twist_body);
  next->modules.resize(n);
  next->drive_acceleration.resize(n);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const Eigen::Vector2d u = u_prev[k] + scale * (u_target[k] - u_prev[k]);
    // Steer toward the line of u (or, nearly stopped, toward the target's line: pre-steer),
    // never faster than the rate limit; a consistent step lands exactly on the line.
    double turn = 0.0;
    if (u.norm() >= threshold) {
      turn = line_angle_from(heading[k], u);
    } else if (u_target[k].norm() >= threshold) {
      turn = line_angle_from(heading[k], u_target[k]);
    }
    turn = std::clamp(turn, -max_turn, max_turn);
    const double angle = wrap_angle(previous.modules[i].angle + turn);
    const double speed = std::cos(angle) * u.x() + std::sin(angle) * u.y();
    next->modules[i] = ModuleState{speed, angle};
    next->drive_acceleration[i] = (speed - speed_prev[k]) / dt;
  }
  return KinematicsStatus::kOk;
}

KinematicsStatus SetpointGenerator::step_module_first(const Setpoint& previous, const Eigen::Vector3d& target,
                                                      double dt, Setpoint* next) const noexcept {
  const int n = kinematics_.size();
  const double threshold = kinematics_.options().hold_speed_threshold;
  const double max_turn = limits_.max_steering_rate * dt;
  next->modules.resize(n);
  next->drive_acceleration.resize(n);
  for (int i = 0; i < n; ++i) {
    const ModuleState& before = previous.modules[i];
    const Eigen::Vector2d heading(std::cos(before.angle), std::sin(before.angle));
    const Eigen::Vector2d u = point_velocity<double>(target, kinematics_.layout().position_body(i));
    double turn = 0.0;
    double target_speed = 0.0;
    if (u.norm() >= threshold) {
      turn = line_angle_from(heading, u);
      target_speed = heading.dot(u) >= 0.0 ? u.norm() : -u.norm();
    }
    const double change = target_speed - before.speed;
    const double allowed = allowed_acceleration(previous.drive_acceleration[i], std::abs(change), dt) * dt;
    const double speed = before.speed + std::clamp(change, -allowed, allowed);
    next->modules[i] = ModuleState{speed, wrap_angle(before.angle + std::clamp(turn, -max_turn, max_turn))};
    next->drive_acceleration[i] = (speed - before.speed) / dt;
  }
  return kinematics_.forward(next->modules, &next->twist_body);
}

}  // namespace swerve
