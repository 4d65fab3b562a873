// Dead reckoning for swerve vehicles: integrates forward-kinematics displacements on SE(2) with
// the exponential map (exact on arcs of constant twist, unlike Euler steps), optionally taking the
// heading from a gyro. Holds the last wheel readings; sizes fixed at construction.
#pragma once

#include <Eigen/Core>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_state.hpp"

namespace swerve {

class Odometry {
 public:
  // `positions` are the current cumulative wheel readings (distance, angle); throws ConfigError
  // when their count differs from the layout's or a value is not finite.
  Odometry(Kinematics kinematics, const ModulePositions& positions,
           const Eigen::Vector3d& pose_world = Eigen::Vector3d::Zero());

  // New cumulative readings: the distance increments and current angles go through weighted or
  // plain forward_delta, then the pose advances by se2_exp of that displacement. With a gyro, the
  // heading change is taken from the gyro (its offset to the pose heading is fixed at the first
  // gyro reading and by the resets). On error the pose and the stored readings are unchanged.
  KinematicsStatus update(const ModulePositions& positions) noexcept;
  KinematicsStatus update(const ModulePositions& positions, double gyro_heading) noexcept;
  KinematicsStatus update(const ModulePositions& positions, const ModuleWeights& weights) noexcept;
  // Velocity-based step: the pose advances by se2_exp(twist_body * dt).
  KinematicsStatus update_with_twist(const Eigen::Vector3d& twist_body, double dt) noexcept;

  const Eigen::Vector3d& pose_world() const { return pose_world_; }  // (x, y, heading), heading wrapped
  const Kinematics& kinematics() const { return kinematics_; }

  // Resets keep the gyro consistent: later gyro readings continue from the new heading.
  KinematicsStatus reset_pose(const Eigen::Vector3d& pose_world, const ModulePositions& positions) noexcept;
  KinematicsStatus reset_translation(const Eigen::Vector2d& translation_world) noexcept;
  KinematicsStatus reset_rotation(double heading_world) noexcept;

 private:
  KinematicsStatus advance(const ModulePositions& positions, const ModuleWeights* weights, const double* gyro) noexcept;

  Kinematics kinematics_;
  ModulePositions previous_;
  Eigen::Vector3d pose_world_;
  bool gyro_seen_ = false;
  double last_gyro_ = 0.0;
  double gyro_offset_ = 0.0;  // pose heading = gyro + offset
};

}  // namespace swerve
