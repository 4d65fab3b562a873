#include "swerve/control/tracking_controller.hpp"

#include <cmath>

#include "swerve/core/config_error.hpp"

namespace swerve {

void TrackingController::set_module_fault(int module, ModuleFault fault) {
  if (!faults_)
    throw ConfigError(std::string(name()) + ".set_module_fault: called on a moved-from controller");
  if (module < 0 || module >= faults_->size()) {
    throw_invalid_field(name(), "set_module_fault.module", module,
                        "must name a module of the vehicle, 0 to " + std::to_string(faults_->size() - 1));
  }
  if (fault != ModuleFault::kNone && fault != ModuleFault::kStuckSteering && fault != ModuleFault::kDeadDrive &&
      fault != ModuleFault::kSteeringSensorLost) {
    throw_invalid_field(name(), "set_module_fault.fault", static_cast<int>(fault), "is not a ModuleFault");
  }
  (*faults_)[module] = fault;
  module_faults_changed();
}

void TrackingController::set_friction_scale(double scale) {
  if (!std::isfinite(scale) || scale <= 0.0 || scale > 10.0) {
    throw_invalid_field(name(), "set_friction_scale.scale", scale, "must be finite and in (0, 10]");
  }
}

void TrackingController::set_module_wear(const Eigen::Ref<const Eigen::VectorXd>& wear) {
  if (wear.size() != faults_->size()) {
    throw_invalid_field(name(), "set_module_wear.wear.size", static_cast<int>(wear.size()),
                        "must be the vehicle's module count, " + std::to_string(faults_->size()));
  }
  for (Eigen::Index i = 0; i < wear.size(); ++i) {
    if (!std::isfinite(wear[i]) || wear[i] < 0.0) {
      throw_invalid_field(name(), "set_module_wear.wear[" + std::to_string(i) + "]", wear[i], "must be finite and >= 0");
    }
  }
}

Eigen::Ref<const Eigen::VectorXd> TrackingController::stand_in_for_lost_angles(
    LostSteeringAngles& angles, const Eigen::Ref<const Eigen::VectorXd>& measured, double measured_at,
    bool* found) noexcept {
  *found = false;
  if (!angles.repair(measured, measured_at)) return measured;
  for (int i = 0; i < faults_->size(); ++i) {
    if (angles.lost(i) && (*faults_)[i] == ModuleFault::kNone) {
      (*faults_)[i] = ModuleFault::kSteeringSensorLost;
      *found = true;
    }
  }
  if (*found) module_faults_changed();
  return angles.repaired();
}

bool TrackingController::find_stuck_steering(SteeringFaultDetector& detector,
                                             const Eigen::Ref<const Eigen::VectorXd>& measured,
                                             double measured_at) noexcept {
  if (measured.size() != 6 + faults_->size() || !detector.observe(measured.tail(faults_->size()), measured_at)) {
    return false;
  }
  bool found = false;
  for (int i = 0; i < faults_->size(); ++i) {
    if (detector.stuck(i) && (*faults_)[i] == ModuleFault::kNone) {
      (*faults_)[i] = ModuleFault::kStuckSteering;
      found = true;
    }
  }
  if (found) module_faults_changed();
  return found;
}

void TrackingController::hold_stuck_angles(const Eigen::Ref<const Eigen::VectorXd>& measured,
                                           Eigen::Ref<Eigen::VectorXd> now) const noexcept {
  for (int i = 0; i < faults_->size(); ++i) {
    const Eigen::Index angle = 6 + i;
    if (steering_stuck(faults_.get(), i) && angle < measured.size() && angle < now.size())
      now[angle] = measured[angle];
  }
}

}  // namespace swerve
