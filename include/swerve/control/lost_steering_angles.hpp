// Stands in for a steering encoder that stopped reporting (a NaN or infinite angle in an otherwise
// good measurement): the module's angle is its last reading turned on by the steering rates sent
// since, within its end stops. One lost encoder then costs the accuracy of its own angle, not the
// whole measurement. Fixed capacity: no allocation after construction.
#pragma once

#include <Eigen/Core>

#include <array>

#include "swerve/control/steering_fault_detector.hpp"
#include "swerve/core/stamped_history.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

class LostSteeringAngles {
 public:
  // Throws ConfigError for a non-positive period.
  LostSteeringAngles(const ModuleLayout& layout, double control_period);

  // The steering rates sent at `t` (s), acting from t until the next commands.
  void commanded(const ModuleArray<ModuleCommand>& commands, double t) noexcept;
  // A measurement (6 + n) taken at `measured_at`. true when some steering angles were not finite
  // and every one of them could be stood in for: repaired() then holds the measurement with those
  // angles replaced and lost() says which. false when every angle was finite, or when one cannot
  // be stood in for (the pose or twist is not finite, an angle was never read, time went back):
  // the measurement is then the caller's to judge as it is. noexcept, no allocation.
  bool repair(const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at) noexcept;
  const Eigen::VectorXd& repaired() const noexcept { return repaired_; }
  // Whether module `module`'s angle was stood in for by the last repair().
  bool lost(int module) const noexcept {
    return module >= 0 && module < modules_ && lost_[static_cast<std::size_t>(module)];
  }
  void reset() noexcept;

 private:
  static constexpr int kHistory = 128;  // commands kept: a measurement up to 127 periods old
  // Module `module`'s steering rates sent over [from, to], integrated (rad).
  double turn_commanded(int module, double from, double to) const noexcept;

  ModuleLimits limits_;
  int modules_;
  double period_;
  StampedHistory<StampedModuleValues, kHistory> rates_;  // the steering rates sent
  std::array<double, kMaxModules> angles_{};  // the last reading, or its stand-in
  std::array<bool, kMaxModules> known_{};
  std::array<bool, kMaxModules> lost_{};
  double angles_at_ = 0.0;  // s: when angles_ held
  Eigen::VectorXd repaired_;
};

}  // namespace swerve
