// Module faults the command map, the controllers and the plant take into account. A stuck
// steering no longer turns: its wheel still drives, so the module's best use is to roll along its
// fixed angle (and be dragged sideways by whatever motion the other modules make). A dead drive
// gives no torque: its wheel rolls free, and its steering still keeps it rolling without drag.
#pragma once

#include <cstdint>
#include <string>

#include "swerve/kinematics/module_state.hpp"

namespace swerve {

enum class ModuleFault : std::uint8_t {
  kNone,
  kStuckSteering,  // the steering holds its angle whatever it is commanded; the drive still works
  kDeadDrive,      // the drive gives no torque (free-rolling wheel); the steering still works
  // The steering angle is no longer measured (its encoder reports NaN); the module itself works,
  // and the controllers follow its angle by the rates they send (LostSteeringAngles).
  kSteeringSensorLost,
};

// The YAML and log word ("none", "stuck_steering", "dead_drive", "steering_sensor_lost").
const char* to_string(ModuleFault fault) noexcept;
// The fault a word names; throws ConfigError naming `field` and the word when it names none.
ModuleFault module_fault_from_string(const std::string& word, const std::string& field);

// One fault per module (kNone: healthy), sized with the layout.
using ModuleFaults = ModuleArray<ModuleFault>;

// Whether module `module`'s steering is stuck under `faults` (null: no faults known).
inline bool steering_stuck(const ModuleFaults* faults, int module) noexcept {
  return faults != nullptr && module >= 0 && module < faults->size() &&
         (*faults)[module] == ModuleFault::kStuckSteering;
}

// Whether module `module`'s drive is dead under `faults` (null: no faults known).
inline bool drive_dead(const ModuleFaults* faults, int module) noexcept {
  return faults != nullptr && module >= 0 && module < faults->size() && (*faults)[module] == ModuleFault::kDeadDrive;
}

// Whether any module of `faults` is faulty.
inline bool any_fault(const ModuleFaults& faults) noexcept {
  for (int i = 0; i < faults.size(); ++i) {
    if (faults[i] != ModuleFault::kNone) return true;
  }
  return false;
}

// What a vehicle with these faults can no longer do without dragging a tire, in words for logs
// and reports: per stuck module, where it sits and the angle it holds, and that it rolls freely only
// in translation along that angle or about a centre of rotation on the line through it
// perpendicular to its wheel; per dead drive, that the module only rolls and the others carry its
// traction. `angles` (n): the steering angles the faulty modules hold. "" without faults.
std::string describe_lost_motions(const ModuleLayout& layout, const ModuleFaults& faults,
                                  const ModuleArray<double>& angles);

}  // namespace swerve
