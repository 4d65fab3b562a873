// Odometry: closed-form arcs for constant twists, gyro heading, resets, bad input.
#include "swerve/kinematics/odometry.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kinematics/test_layouts.hpp"

namespace swerve {
namespace {

// Pose after time t of a body moving with constant body twist from the origin (integral of
// R(omega s) v ds): the circle through the origin with radius |v| / omega.
Eigen::Vector3d constant_twist_pose(const Eigen::Vector3d& twist, double t) {
  const double w = twist.z();
  const double s = std::sin(w * t) / w;
  const double c = (1.0 - std::cos(w * t)) / w;
  return {s * twist.x() - c * twist.y(), c * twist.x() + s * twist.y(), wrap_angle(w * t)};
}

// Cumulative wheel readings after driving `twist` for `steps` of `dt`.
void advance_wheels(const Kinematics& kinematics, const Eigen::Vector3d& twist, double dt, ModulePositions* wheels) {
  ModuleStates states;
  kinematics.inverse(twist, &states);
  for (int i = 0; i < wheels->size(); ++i) {
    (*wheels)[i].distance += states[i].speed * dt;
    (*wheels)[i].angle = states[i].angle;
  }
}

TEST(Odometry, ConstantTwistIsIntegratedExactlyOnItsArcForEveryLayout) {
  const Eigen::Vector3d twist(1.0, 0.5, 0.8);
  for (const auto& [name, layout] : testing::layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    ModulePositions wheels(layout.size());
    advance_wheels(kinematics, twist, 0.0, &wheels);  // angles only
    Odometry odometry(kinematics, wheels);
    for (int step = 0; step < 50; ++step) {  // 50 coarse 0.1 s steps: Euler would be off by cm
      advance_wheels(kinematics, twist, 0.1, &wheels);
      ASSERT_EQ(odometry.update(wheels), KinematicsStatus::kOk);
    }
    const Eigen::Vector3d expected = constant_twist_pose(twist, 5.0);
    EXPECT_NEAR((odometry.pose_world().head<2>() - expected.head<2>()).norm(), 0.0, 1e-9);
    EXPECT_NEAR(wrap_angle(odometry.pose_world().z() - expected.z()), 0.0, 1e-12);
  }
}

TEST(Odometry, VelocityStepsAreArcExactToo) {
  Odometry odometry(Kinematics(ModuleLayout::triangle(0.4, 0.05)), ModulePositions(3));
  const Eigen::Vector3d twist(-0.4, 0.9, -1.3);
  for (int step = 0; step < 20; ++step) ASSERT_EQ(odometry.update_with_twist(twist, 0.05), KinematicsStatus::kOk);
  const Eigen::Vector3d expected = constant_twist_pose(twist, 1.0);
  EXPECT_NEAR((odometry.pose_world() - expected).norm(), 0.0, 1e-12);
}

TEST(Odometry, GyroHeadingOverridesWheelRotationFromItsFirstReading) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModulePositions wheels(4);
  Odometry odometry(kinematics, wheels, {0.0, 0.0, 0.3});
  advance_wheels(kinematics, {1.0, 0.0, 0.0}, 0.1, &wheels);
  ASSERT_EQ(odometry.update(wheels, 2.0), KinematicsStatus::kOk);  // gyro zero is not the pose's zero
  EXPECT_NEAR(odometry.pose_world().z(), 0.3, 1e-12);
  // The wheels claim straight driving, the gyro says the body turned 0.5 rad: trust the gyro.
  advance_wheels(kinematics, {1.0, 0.0, 0.0}, 0.1, &wheels);
  ASSERT_EQ(odometry.update(wheels, 2.5), KinematicsStatus::kOk);
  EXPECT_NEAR(odometry.pose_world().z(), 0.8, 1e-12);
}

TEST(Odometry, ResetsMoveThePoseAndKeepTheGyroConsistent) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModulePositions wheels(4);
  Odometry odometry(kinematics, wheels);
  odometry.update(wheels, 1.0);
  ASSERT_EQ(odometry.reset_rotation(-1.0), KinematicsStatus::kOk);
  odometry.update(wheels, 1.2);
  EXPECT_NEAR(odometry.pose_world().z(), -0.8, 1e-12);
  ASSERT_EQ(odometry.reset_translation({3.0, 4.0}), KinematicsStatus::kOk);
  EXPECT_DOUBLE_EQ(odometry.pose_world().x(), 3.0);
  EXPECT_NEAR(odometry.pose_world().z(), -0.8, 1e-12);
  ModulePositions moved(4);
  for (ModulePosition& p : moved) p.distance = 10.0;
  ASSERT_EQ(odometry.reset_pose({1.0, 1.0, 0.0}, moved), KinematicsStatus::kOk);
  odometry.update(moved, 1.2);  // no distance since the reset, gyro unchanged
  EXPECT_NEAR((odometry.pose_world() - Eigen::Vector3d(1.0, 1.0, 0.0)).norm(), 0.0, 1e-12);
}

TEST(Odometry, BadReadingsLeaveThePoseUnchanged) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModulePositions wheels(4);
  Odometry odometry(kinematics, wheels, {1.0, 2.0, 0.5});
  ModulePositions bad = wheels;
  bad[2].distance = NAN;
  EXPECT_EQ(odometry.update(bad), KinematicsStatus::kNonFiniteInput);
  EXPECT_EQ(odometry.update(ModulePositions(3)), KinematicsStatus::kWrongModuleCount);
  EXPECT_EQ(odometry.update(wheels, INFINITY), KinematicsStatus::kNonFiniteInput);
  EXPECT_EQ(odometry.update_with_twist({1.0, 0.0, 0.0}, -0.1), KinematicsStatus::kInvalidDt);
  EXPECT_EQ(odometry.pose_world(), Eigen::Vector3d(1.0, 2.0, 0.5));
  EXPECT_THROW(Odometry(kinematics, ModulePositions(2)), ConfigError);
}

TEST(Odometry, WeightedUpdateIgnoresASlippingWheel) {
  const Kinematics kinematics(ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05));
  ModulePositions wheels(6);
  Odometry odometry(kinematics, wheels);
  advance_wheels(kinematics, {1.0, 0.0, 0.0}, 1.0, &wheels);
  wheels[3].distance += 0.7;  // spun without moving the body
  ModuleWeights weights(6, 1.0);
  weights[3] = 0.0;
  ASSERT_EQ(odometry.update(wheels, weights), KinematicsStatus::kOk);
  EXPECT_NEAR((odometry.pose_world() - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace swerve
