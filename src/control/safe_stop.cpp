#include "swerve/control/safe_stop.hpp"

#include <algorithm>
#include <cmath>

namespace swerve {

const char* to_string(CommandSource source) noexcept {
  switch (source) {
    case CommandSource::kOptimizer: return "optimizer";
    case CommandSource::kTrackingFirst: return "tracking_first";
    case CommandSource::kPreviousPlan: return "previous_plan";
    case CommandSource::kBaseline: return "baseline";
    case CommandSource::kSafeStop: return "safe_stop";
  }
  return "unknown";
}

bool is_plausible_state(const Eigen::Ref<const Eigen::VectorXd>& measured, const ModuleLayout& layout) noexcept {
  if (measured.size() != 6 + layout.size() || !measured.allFinite()) return false;
  double reach = 0.0;
  for (const Eigen::Vector2d& p : layout.positions_body()) reach = std::max(reach, p.norm());
  const double max_speed = 10.0 * layout.limits().max_drive_speed;
  const double max_yaw_rate = max_speed / std::max(reach, 1e-3);
  return measured.segment<2>(3).norm() <= max_speed && std::abs(measured[5]) <= max_yaw_rate;
}

void fill_safe_stop(const ModuleLayout& layout, double dt, const Eigen::Ref<const Eigen::VectorXd>& measured,
                    ModuleArray<ModuleCommand>* commands) noexcept {
  const bool angles_usable = measured.size() == 6 + layout.size() && measured.segment(6, layout.size()).allFinite();
  const double max_wheel_step = layout.limits().max_drive_acceleration * dt / layout.wheel_radius();
  for (int i = 0; i < commands->size(); ++i) {
    ModuleCommand& command = (*commands)[i];
    if (angles_usable) command.steering_angle = wrap_angle(measured[6 + i]);
    if (!std::isfinite(command.steering_angle)) command.steering_angle = 0.0;
    command.steering_rate = 0.0;
    const double speed = std::isfinite(command.wheel_speed) ? command.wheel_speed : 0.0;
    command.wheel_speed = speed > 0 ? std::max(0.0, speed - max_wheel_step) : std::min(0.0, speed + max_wheel_step);
  }
}

}  // namespace swerve
