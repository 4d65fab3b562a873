// The only state of swerve kinematics, kept apart from the stateless Kinematics: for each module,
// the heading it was last commanded to and whether that command drove it forwards or reversed
// (the flip decision the hysteresis band protects). Resettable explicitly.
#pragma once

#include "swerve/kinematics/module_state.hpp"

namespace swerve {

class ModuleHeadingMemory {
 public:
  // All headings unknown: a module held before any command points straight ahead (angle 0).
  explicit ModuleHeadingMemory(int module_count) : entries_(module_count) {}

  int size() const { return entries_.size(); }

  // Forgets every heading and flip decision.
  void reset() noexcept;
  // Seeds the headings from measured module angles (e.g. at start-up) with no flip decision yet.
  // kWrongModuleCount / kNonFiniteInput leave the memory unchanged.
  KinematicsStatus reset(const ModuleStates& measured) noexcept;

  bool known(int module) const { return entries_[module].known; }
  // Remembered heading, wrapped; 0 when unknown.
  double angle(int module) const { return entries_[module].angle; }
  double cos_angle(int module) const { return entries_[module].cos_angle; }
  double sin_angle(int module) const { return entries_[module].sin_angle; }
  // +1 when the last command drove along the raw inverse-kinematics direction, -1 when it was
  // flipped (angle + pi, speed reversed), 0 when no decision was made yet.
  int drive_sign(int module) const { return entries_[module].drive_sign; }
  // The shared decision of the whole-robot flip mode (same meaning as drive_sign).
  int robot_drive_sign() const { return robot_drive_sign_; }

  // Records a command (called by Kinematics::optimize; public so callers that build module
  // commands by other means can keep the memory in step). `drive_sign` 0 keeps the old decision.
  void remember(int module, double angle, int drive_sign) noexcept;
  // The same with the heading's cosine and sine already known (the per-cycle path avoids the trig);
  // `angle` must be wrapped and match them.
  void remember(int module, double angle, double cos_angle, double sin_angle, int drive_sign) noexcept;
  void set_robot_drive_sign(int drive_sign) noexcept { robot_drive_sign_ = drive_sign; }

 private:
  struct Entry {
    double angle = 0.0;
    double cos_angle = 1.0;  // cached so the flip test is a dot product, not a trig call
    double sin_angle = 0.0;
    int drive_sign = 0;
    bool known = false;
  };
  ModuleArray<Entry> entries_;
  int robot_drive_sign_ = 0;
};

}  // namespace swerve
