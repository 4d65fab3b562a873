// Mathematical constants every layer shares, so none defines its own: the core holds them because
// kinematics, models, solvers and the app all reach down to it.
#pragma once

namespace swerve {

inline constexpr double kPi = 3.14159265358979323846;

}  // namespace swerve
