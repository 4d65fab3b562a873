#include "swerve/kinematics/odometry.hpp"

#include <cmath>
#include <string>

#include "swerve/kinematics/se2.hpp"

namespace swerve {
namespace {

bool finite_positions(const ModulePositions& positions) {
  for (const ModulePosition& p : positions) {
    if (!std::isfinite(p.distance) || !std::isfinite(p.angle)) return false;
  }
  return true;
}

}  // namespace

Odometry::Odometry(Kinematics kinematics, const ModulePositions& positions, const Eigen::Vector3d& pose_world)
    : kinematics_(std::move(kinematics)), previous_(positions), pose_world_(pose_world) {
  if (positions.size() != kinematics_.size()) {
    throw ConfigError("Odometry: positions size = " + std::to_string(positions.size()) + ": must equal the " +
                      std::to_string(kinematics_.size()) + " modules of the layout");
  }
  if (!finite_positions(positions)) throw ConfigError("Odometry: positions: must be finite");
  if (!pose_world.allFinite()) throw ConfigError("Odometry: pose_world: must be finite");
  pose_world_.z() = wrap_angle(pose_world_.z());
}

KinematicsStatus Odometry::advance(const ModulePositions& positions, const ModuleWeights* weights,
                                   const double* gyro) noexcept {
  if (positions.size() != kinematics_.size()) return KinematicsStatus::kWrongModuleCount;
  if (!finite_positions(positions) || (gyro != nullptr && !std::isfinite(*gyro))) {
    return KinematicsStatus::kNonFiniteInput;
  }
  ModulePositions deltas = positions;
  for (int i = 0; i < deltas.size(); ++i) deltas[i].distance -= previous_[i].distance;
  Eigen::Vector3d delta_body;
  const KinematicsStatus status = weights != nullptr ? kinematics_.forward_delta(deltas, *weights, &delta_body)
                                                     : kinematics_.forward_delta(deltas, &delta_body);
  if (status != KinematicsStatus::kOk) return status;
  if (gyro != nullptr) {
    if (gyro_seen_) delta_body.z() = wrap_angle(*gyro + gyro_offset_ - pose_world_.z());
    pose_world_ = compose_pose(pose_world_, delta_body);
    gyro_seen_ = true;
    last_gyro_ = *gyro;
    gyro_offset_ = pose_world_.z() - *gyro;
  } else {
    pose_world_ = compose_pose(pose_world_, delta_body);
  }
  previous_ = positions;
  return KinematicsStatus::kOk;
}

KinematicsStatus Odometry::update(const ModulePositions& positions) noexcept {
  return advance(positions, nullptr, nullptr);
}

KinematicsStatus Odometry::update(const ModulePositions& positions, double gyro_heading) noexcept {
  return advance(positions, nullptr, &gyro_heading);
}

KinematicsStatus Odometry::update(const ModulePositions& positions, const ModuleWeights& weights) noexcept {
  return advance(positions, &weights, nullptr);
}

KinematicsStatus Odometry::update_with_twist(const Eigen::Vector3d& twist_body, double dt) noexcept {
  if (!twist_body.allFinite()) return KinematicsStatus::kNonFiniteInput;
  if (!std::isfinite(dt) || dt < 0.0) return KinematicsStatus::kInvalidDt;
  pose_world_ = compose_pose(pose_world_, twist_body * dt);
  if (gyro_seen_) gyro_offset_ = pose_world_.z() - last_gyro_;
  return KinematicsStatus::kOk;
}

KinematicsStatus Odometry::reset_pose(const Eigen::Vector3d& pose_world, const ModulePositions& positions) noexcept {
  if (positions.size() != kinematics_.size()) return KinematicsStatus::kWrongModuleCount;
  if (!pose_world.allFinite() || !finite_positions(positions)) return KinematicsStatus::kNonFiniteInput;
  pose_world_ = pose_world;
  pose_world_.z() = wrap_angle(pose_world.z());
  previous_ = positions;
  gyro_offset_ = pose_world_.z() - last_gyro_;
  return KinematicsStatus::kOk;
}

KinematicsStatus Odometry::reset_translation(const Eigen::Vector2d& translation_world) noexcept {
  if (!translation_world.allFinite()) return KinematicsStatus::kNonFiniteInput;
  pose_world_.head<2>() = translation_world;
  return KinematicsStatus::kOk;
}

KinematicsStatus Odometry::reset_rotation(double heading_world) noexcept {
  if (!std::isfinite(heading_world)) return KinematicsStatus::kNonFiniteInput;
  pose_world_.z() = wrap_angle(heading_world);
  gyro_offset_ = pose_world_.z() - last_gyro_;
  return KinematicsStatus::kOk;
}

}  // namespace swerve
