// The commands every controller falls back to when it cannot trust its input or its plan: hold
// each steering angle and bring the wheels to rest at the drive's acceleration limit, plus the
// plausibility check that decides when a measured state cannot be trusted.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/module_layout.hpp"
#include "swerve/control/tracking_controller.hpp"

namespace swerve {

// Finite, of the right size, and physically possible for this vehicle: body speed at most
// 10 x the drive speed limit, yaw rate at most 10 x what the drive limit allows at the outermost
// module. A state beyond that is a sensor fault, not a situation to control.
bool is_plausible_state(const Eigen::Ref<const Eigen::VectorXd>& measured, const ModuleLayout& layout) noexcept;

// Overwrites `commands` with a safe stop: steering rate 0 at the measured angle (or, when the
// measurement is unusable, the angle last commanded), wheel speed one acceleration-limited step
// closer to 0 from the last command.
void fill_safe_stop(const ModuleLayout& layout, double dt, const Eigen::Ref<const Eigen::VectorXd>& measured,
                    ModuleArray<ModuleCommand>* commands) noexcept;

}  // namespace swerve
