// Planar rigid-body helpers shared by odometry, discretisation and the controller: the SE(2)
// exponential and logarithm on (x, y, heading) triples, pose composition, field-to-body twist
// conversion and the discretisation of a twist held over one control period.
#pragma once

#include <Eigen/Core>

#include <cmath>

#include "swerve/kinematics/module_state.hpp"
#include "swerve/core/scalar.hpp"

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

// The exponential map and pose composition for any scalar type (ceres::Jet in the prediction
// model's derivatives); se2_exp and compose_pose above are these at double. The wrap of the heading
// shifts by whole turns chosen on the value, so derivatives pass through unchanged.
// Below this rotation the closed forms of se2_exp and se2_log lose digits to cancellation; the
// Taylor series used instead are accurate to O(theta^6) ~ 1e-24 there.
inline constexpr double kSe2SmallAngle = 1e-4;

template <typename T>
T wrap_angle_of(const T& angle) {
  return angle + (wrap_angle(scalar_value(angle)) - scalar_value(angle));
}

template <typename T>
Eigen::Matrix<T, 3, 1> se2_exp_of(const Eigen::Matrix<T, 3, 1>& delta_body) {
  using std::abs;
  using std::cos;
  using std::sin;
  const T& theta = delta_body.z();
  T a;  // sin(theta) / theta
  T b;  // (1 - cos(theta)) / theta
  if (abs(theta) < T(kSe2SmallAngle)) {
    const T t2 = theta * theta;
    a = T(1.0) - t2 / 6.0 + t2 * t2 / 120.0;
    b = theta * (T(0.5) - t2 / 24.0);
  } else {
    a = sin(theta) / theta;
    b = (T(1.0) - cos(theta)) / theta;
  }
  return {a * delta_body.x() - b * delta_body.y(), b * delta_body.x() + a * delta_body.y(), theta};
}

template <typename T>
Eigen::Matrix<T, 3, 1> compose_pose_of(const Eigen::Matrix<T, 3, 1>& pose_world, const Eigen::Matrix<T, 3, 1>& delta_body) {
  using std::cos;
  using std::sin;
  const Eigen::Matrix<T, 3, 1> step = se2_exp_of<T>(delta_body);
  const T c = cos(pose_world.z());
  const T s = sin(pose_world.z());
  return {pose_world.x() + c * step.x() - s * step.y(), pose_world.y() + s * step.x() + c * step.y(),
          wrap_angle_of<T>(pose_world.z() + step.z())};
}

}  // namespace swerve
