// Planar rigid-body helpers shared by odometry, discretisation and the controller: the SE(2)
// exponential and logarithm on (x, y, heading) triples, pose composition, field-to-body twist
// conversion and the discretisation of a twist held over one control period.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/module_state.hpp"

namespace swerve {

// Pose (x, y, heading) of the body after moving with body twist `delta_body` = (dx, dy, dpsi)
// (a twist times its duration) for unit time from the identity: the SE(2) exponential map
// (Lynch & Park, Modern Robotics, 2017, sec. 3.3.3, restricted to the plane). Exact on arcs.
Eigen::Vector3d se2_exp(const Eigen::Vector3d& delta_body) noexcept;

// Inverse of se2_exp: the constant body twist times duration that carries the identity to
// `pose_delta` (x, y, heading; heading taken as given, not wrapped).
Eigen::Vector3d se2_log(const Eigen::Vector3d& pose_delta) noexcept;

// `pose_world` followed by `delta_body` expressed in the body frame of `pose_world`; the result's
// heading is wrapped to (-pi, pi].
Eigen::Vector3d compose_pose(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& delta_body) noexcept;

// Field-relative twist (vx_world, vy_world, omega) to the body twist at heading `heading_world`.
Eigen::Vector3d twist_world_to_body(const Eigen::Vector3d& twist_world, double heading_world) noexcept;
Eigen::Vector3d twist_body_to_world(const Eigen::Vector3d& twist_body, double heading_world) noexcept;

// The twist that, held constant over `dt`, ends at the pose (vx dt, vy dt, omega dt) that the
// command names when its translation and rotation are read independently: se2_log(that) / dt.
// Removes the translational skew that appears when a robot translates and rotates at once.
// kInvalidDt for dt <= 0, kNonFiniteInput for NaN/inf; on error *twist_out is zero.
KinematicsStatus discretize(const Eigen::Vector3d& twist_body, double dt, Eigen::Vector3d* twist_out) noexcept;

}  // namespace swerve
