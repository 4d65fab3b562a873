// Body-first motion profiles: turns a desired chassis twist into a sequence of per-step setpoints
// every module can follow (steering rate, drive acceleration, optionally jerk), so the modules stay
// kinematically consistent throughout a transition. A module-first mode is kept for comparison.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

struct ProfileLimits {
  double max_drive_speed = 2.0;         // m/s, per module
  double max_drive_acceleration = 2.0;  // m/s^2, per module (rate of the signed drive speed)
  double max_steering_rate = 1.0;       // rad/s, per module
  double max_drive_jerk = 0.0;          // m/s^3; 0 switches the low-jerk profile off

  static ProfileLimits from_module_limits(const ModuleLimits& limits, double max_drive_jerk = 0.0);
  // Throws ConfigError naming the field and value.
  void validate() const;
};

enum class ProfileMode {
  kBodyFirst,    // scale the chassis step so that no module breaks a limit (modules stay consistent)
  kModuleFirst,  // rate-limit each module towards its own target, then report their FK twist
};

struct Setpoint {
  Eigen::Vector3d twist_body = Eigen::Vector3d::Zero();
  ModuleStates modules;                    // commanded module states (signed speed, angle)
  ModuleArray<double> drive_acceleration;  // signed-speed change of the last step / dt, m/s^2
};

class SetpointGenerator {
 public:
  // Throws ConfigError for invalid limits.
  SetpointGenerator(Kinematics kinematics, ProfileLimits limits, ProfileMode mode = ProfileMode::kBodyFirst);

  // A standstill setpoint with the modules at the given headings (all 0 when `angles` is null).
  // Throws ConfigError when `angles` has the wrong size or non-finite angles.
  Setpoint stopped(const ModuleStates* angles = nullptr) const;

  // One step of length dt from `previous` towards `target_twist_body` (desaturated to
  // max_drive_speed first). Body-first: previous.twist_body gives the module velocities and
  // previous.modules only their headings; the step is previous + s (target - previous) with the
  // largest s in [0, 1] (per-module bisection) such that every moving module turns by at most
  // max_steering_rate dt (modulo pi: a module may reverse its drive instead) and changes its
  // signed speed by at most the allowed acceleration times dt. Rules:
  //  - stop-then-resteer: when every moving module would have to reverse its direction of travel,
  //    the step aims at zero twist first; the modules then re-steer at rest;
  //  - a module slower than the hold threshold pre-steers toward its target heading at the steering
  //    rate limit (so a stopped robot rotates its wheels before it drives);
  //  - low jerk (max_drive_jerk > 0): allowed acceleration = min(max, |a_prev| + j dt,
  //    sqrt(2 j |remaining speed change|)), which ramps up and down at ~j without overshoot.
  // Errors (non-finite, wrong sizes, dt <= 0): *next = previous with zero twist and speeds.
  KinematicsStatus step(const Setpoint& previous, const Eigen::Vector3d& target_twist_body, double dt,
                        Setpoint* next) const noexcept;

  const Kinematics& kinematics() const { return kinematics_; }
  const ProfileLimits& limits() const { return limits_; }
  ProfileMode mode() const { return mode_; }

 private:
  KinematicsStatus step_body_first(const Setpoint& previous, const Eigen::Vector3d& target, double dt,
                                   Setpoint* next) const noexcept;
  KinematicsStatus step_module_first(const Setpoint& previous, const Eigen::Vector3d& target, double dt,
                                     Setpoint* next) const noexcept;
  double allowed_acceleration(double previous_acceleration, double remaining, double dt) const noexcept;

  Kinematics kinematics_;
  ProfileLimits limits_;
  ProfileMode mode_;
};

}  // namespace swerve
