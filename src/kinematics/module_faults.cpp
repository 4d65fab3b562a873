#include "swerve/kinematics/module_faults.hpp"

#include <cmath>
#include <sstream>

#include "swerve/core/config_error.hpp"

namespace swerve {

const char* to_string(ModuleFault fault) noexcept {
  switch (fault) {
    case ModuleFault::kNone:
      return "none";
    case ModuleFault::kStuckSteering:
      return "stuck_steering";
    case ModuleFault::kDeadDrive:
      return "dead_drive";
    case ModuleFault::kSteeringSensorLost:
      return "steering_sensor_lost";
  }
  return "unknown";
}

ModuleFault module_fault_from_string(const std::string& word, const std::string& field) {
  for (ModuleFault fault :
       {ModuleFault::kNone, ModuleFault::kStuckSteering, ModuleFault::kDeadDrive, ModuleFault::kSteeringSensorLost}) {
    if (word == to_string(fault)) return fault;
  }
  throw_invalid_field("", field, word, "must be one of none, stuck_steering, dead_drive, steering_sensor_lost");
}

std::string describe_lost_motions(const ModuleLayout& layout, const ModuleFaults& faults,
                                  const ModuleArray<double>& angles) {
  std::ostringstream text;
  for (int i = 0; i < faults.size() && i < layout.size(); ++i) {
    if (faults[i] == ModuleFault::kDeadDrive) {
      if (text.tellp() > 0) text << "; ";
      text << "module " << i << " has a dead drive: it steers and rolls free, the other modules carry its traction";
      continue;
    }
    if (faults[i] == ModuleFault::kSteeringSensorLost) {
      if (text.tellp() > 0) text << "; ";
      text << "module " << i << "'s steering angle is not measured: it is followed by the rates sent";
      continue;
    }
    if (faults[i] != ModuleFault::kStuckSteering) continue;
    const double angle = i < angles.size() ? angles[i] : 0.0;
    if (text.tellp() > 0) text << "; ";
    // A wheel at angle a rolls freely when its contact velocity points along a (or against it):
    // about a centre of rotation on the line through the module perpendicular to its wheel, or in
    // translation along a. Everything else drags its tire sideways.
    const Eigen::Vector2d& at = layout.position_body(i);
    text << "module " << i << " at (" << at.x() << ", " << at.y() << ") m stuck at " << angle
         << " rad: it rolls freely only in translation along " << angle
         << " rad and about centres of rotation on the line through it perpendicular to its wheel; "
         << "other motions drag its tire";
  }
  return text.str();
}

}  // namespace swerve
