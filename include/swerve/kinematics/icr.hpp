// Instantaneous centre of rotation (ICR) implied by module headings, and how far the modules are
// from agreeing on one: the wheel normals of a kinematically consistent swerve command all pass
// through one point (or are parallel, for pure translation). Used to check and synchronise steering.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

struct IcrEstimate {
  // True for a pure translation (the ICR is at infinity): then direction_body holds the unit
  // direction of travel (up to sign) and center_body is unused.
  bool at_infinity = true;
  Eigen::Vector2d center_body = Eigen::Vector2d::Zero();
  Eigen::Vector2d direction_body = Eigen::Vector2d::UnitX();
  // Per module: the angle (rad, in (-pi/2, pi/2]; headings count modulo pi) from the module's
  // heading to the velocity the best-fit rigid motion gives that point; 0 for a module at the ICR.
  ModuleArray<double> module_error;
  // RMS of module_error: 0 when every wheel normal meets in one point.
  double residual = 0.0;
};

// Best-fit ICR from the headings of `states` (speeds are ignored): the rigid twist xi minimising
// sum_i (n_i . A_i xi)^2 over unit xi (rotation scaled by the layout's RMS radius), n_i the wheel
// normals; its null direction is exact when the headings agree. On error: a default estimate.
KinematicsStatus estimate_icr(const Kinematics& kinematics, const ModuleStates& states, IcrEstimate* icr) noexcept;

// The ICR two modules agree on: where their normals cross. module_error/residual cover the two
// modules only (always ~0: two lines always meet, possibly at infinity). For multi-axle vehicles,
// comparing the pair ICRs of the axles shows which axle disagrees.
KinematicsStatus pair_icr(const Kinematics& kinematics, const ModuleStates& states, int module_a, int module_b,
                          IcrEstimate* icr) noexcept;

// ICR of a body twist: the point with zero velocity, (-vy/omega, vx/omega).
IcrEstimate icr_of_twist(const Eigen::Vector3d& twist_body) noexcept;

}  // namespace swerve
