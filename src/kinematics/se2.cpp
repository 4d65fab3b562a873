#include "swerve/kinematics/se2.hpp"

#include <cmath>

namespace swerve {
namespace {

bool finite(const Eigen::Vector3d& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

}  // namespace

Eigen::Vector3d se2_exp(const Eigen::Vector3d& delta_body) noexcept { return se2_exp_of<double>(delta_body); }

Eigen::Vector3d se2_log(const Eigen::Vector3d& pose_delta) noexcept {
  const double theta = pose_delta.z();
  const double half = 0.5 * theta;
  // half * cot(half) is the diagonal of the inverse of se2_exp's 2x2 block [[a, -b], [b, a]].
  double c;
  if (std::abs(theta) < kSe2SmallAngle) {
    c = 1.0 - theta * theta / 12.0;
  } else {
    c = half * std::cos(half) / std::sin(half);
  }
  return {c * pose_delta.x() + half * pose_delta.y(), -half * pose_delta.x() + c * pose_delta.y(), theta};
}

Eigen::Vector3d compose_pose(const Eigen::Vector3d& pose_world, const Eigen::Vector3d& delta_body) noexcept {
  return compose_pose_of<double>(pose_world, delta_body);
}

Eigen::Vector3d twist_world_to_body(const Eigen::Vector3d& twist_world, double heading_world) noexcept {
  const double c = std::cos(heading_world);
  const double s = std::sin(heading_world);
  return {c * twist_world.x() + s * twist_world.y(), -s * twist_world.x() + c * twist_world.y(), twist_world.z()};
}

Eigen::Vector3d twist_body_to_world(const Eigen::Vector3d& twist_body, double heading_world) noexcept {
  return twist_world_to_body(twist_body, -heading_world);
}

KinematicsStatus discretize(const Eigen::Vector3d& twist_body, double dt, Eigen::Vector3d* twist_out) noexcept {
  *twist_out = Eigen::Vector3d::Zero();
  if (!finite(twist_body)) return KinematicsStatus::kNonFiniteInput;
  if (!std::isfinite(dt) || dt <= 0.0) return KinematicsStatus::kInvalidDt;
  *twist_out = se2_log(twist_body * dt) / dt;
  return KinematicsStatus::kOk;
}

}  // namespace swerve
