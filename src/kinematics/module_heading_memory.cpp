#include "swerve/kinematics/module_heading_memory.hpp"

#include <cmath>

namespace swerve {

void ModuleHeadingMemory::reset() noexcept {
  for (Entry& entry : entries_) entry = Entry{};
  robot_drive_sign_ = 0;
}

KinematicsStatus ModuleHeadingMemory::reset(const ModuleStates& measured) noexcept {
  if (measured.size() != size()) return KinematicsStatus::kWrongModuleCount;
  for (const ModuleState& state : measured) {
    if (!std::isfinite(state.angle)) return KinematicsStatus::kNonFiniteInput;
  }
  reset();
  for (int i = 0; i < size(); ++i) remember(i, measured[i].angle, 0);
  return KinematicsStatus::kOk;
}

void ModuleHeadingMemory::remember(int module, double angle, int drive_sign) noexcept {
  Entry& entry = entries_[module];
  entry.angle = wrap_angle(angle);
  entry.cos_angle = std::cos(entry.angle);
  entry.sin_angle = std::sin(entry.angle);
  if (drive_sign != 0) entry.drive_sign = drive_sign > 0 ? 1 : -1;
  entry.known = true;
}

void ModuleHeadingMemory::remember(int module, double angle, double cos_angle, double sin_angle,
                                   int drive_sign) noexcept {
  SWERVE_DCHECK(std::abs(std::cos(angle) - cos_angle) < 1e-9 && std::abs(std::sin(angle) - sin_angle) < 1e-9);
  Entry& entry = entries_[module];
  entry.angle = angle;
  entry.cos_angle = cos_angle;
  entry.sin_angle = sin_angle;
  if (drive_sign != 0) entry.drive_sign = drive_sign > 0 ? 1 : -1;
  entry.known = true;
}

}  // namespace swerve
