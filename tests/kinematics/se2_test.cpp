// SE(2) helpers: closed-form arcs, exp/log inverse pair, discretisation and frame conversion.
#include "swerve/kinematics/se2.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace swerve {
namespace {

TEST(Se2, ExpOfAPureRotationTwistTracesTheArcOfACircle) {
  // Driving forward at 1 m/s while turning at 1 rad/s for pi/2 s: a quarter circle of radius 1.
  const Eigen::Vector3d pose = se2_exp({kPi / 2.0, 0.0, kPi / 2.0});
  EXPECT_NEAR(pose.x(), 1.0, 1e-12);
  EXPECT_NEAR(pose.y(), 1.0, 1e-12);
  EXPECT_NEAR(pose.z(), kPi / 2.0, 1e-15);
}

TEST(Se2, ExpWithoutRotationIsTheStraightLine) {
  const Eigen::Vector3d pose = se2_exp({0.3, -0.2, 0.0});
  EXPECT_DOUBLE_EQ(pose.x(), 0.3);
  EXPECT_DOUBLE_EQ(pose.y(), -0.2);
}

TEST(Se2, LogInvertsExpAcrossSmallAndLargeRotations) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> value(-3.0, 3.0);
  for (double theta : {0.0, 1e-9, 1e-5, 2e-4, 0.3, -2.0, 3.1}) {
    const Eigen::Vector3d delta(value(rng), value(rng), theta);
    const Eigen::Vector3d round_trip = se2_log(se2_exp(delta));
    EXPECT_NEAR((round_trip - delta).norm(), 0.0, 1e-12) << "theta " << theta;
  }
}

TEST(Se2, ComposeAppliesTheStepInTheBodyFrameAndWrapsHeading) {
  const Eigen::Vector3d pose = compose_pose({1.0, 2.0, kPi / 2.0}, {1.0, 0.0, 0.0});
  EXPECT_NEAR(pose.x(), 1.0, 1e-12);  // forward in the body is +y in the world
  EXPECT_NEAR(pose.y(), 3.0, 1e-12);
  const Eigen::Vector3d wrapped = compose_pose({0.0, 0.0, 3.0}, {0.0, 0.0, 0.5});
  EXPECT_NEAR(wrapped.z(), 3.5 - 2.0 * kPi, 1e-12);
}

TEST(Se2, FieldRelativeTwistIsRotatedIntoTheBody) {
  // Heading 90 deg: the world +x direction is the body's right (-y).
  const Eigen::Vector3d body = twist_world_to_body({1.0, 0.0, 0.4}, kPi / 2.0);
  EXPECT_NEAR(body.x(), 0.0, 1e-12);
  EXPECT_NEAR(body.y(), -1.0, 1e-12);
  EXPECT_DOUBLE_EQ(body.z(), 0.4);
  EXPECT_NEAR((twist_body_to_world(body, kPi / 2.0) - Eigen::Vector3d(1.0, 0.0, 0.4)).norm(), 0.0, 1e-12);
}

TEST(Discretize, HeldTwistLandsOnTheStraightLineTargetPose) {
  const Eigen::Vector3d command(1.0, 0.5, 2.0);
  const double dt = 0.1;
  Eigen::Vector3d twist;
  ASSERT_EQ(discretize(command, dt, &twist), KinematicsStatus::kOk);
  const Eigen::Vector3d reached = se2_exp(twist * dt);
  EXPECT_NEAR((reached - command * dt).norm(), 0.0, 1e-12);
  // The correction is real: the raw command would drift sideways.
  EXPECT_GT((se2_exp(command * dt) - command * dt).norm(), 1e-3);
}

TEST(Discretize, IsTheIdentityWithoutRotation) {
  Eigen::Vector3d twist;
  ASSERT_EQ(discretize({1.0, -0.5, 0.0}, 0.02, &twist), KinematicsStatus::kOk);
  EXPECT_NEAR((twist - Eigen::Vector3d(1.0, -0.5, 0.0)).norm(), 0.0, 1e-15);
}

TEST(Discretize, RejectsNonPositiveDtAndNonFiniteTwistWithZeroOutput) {
  Eigen::Vector3d twist(9.0, 9.0, 9.0);
  EXPECT_EQ(discretize({1.0, 0.0, 1.0}, -0.01, &twist), KinematicsStatus::kInvalidDt);
  EXPECT_EQ(twist, Eigen::Vector3d::Zero());
  EXPECT_EQ(discretize({1.0, 0.0, 1.0}, 0.0, &twist), KinematicsStatus::kInvalidDt);
  EXPECT_EQ(discretize({NAN, 0.0, 1.0}, 0.02, &twist), KinematicsStatus::kNonFiniteInput);
  EXPECT_TRUE(twist.allFinite());
}

TEST(WrapAngle, MapsIntoMinusPiExclusivePiInclusive) {
  EXPECT_DOUBLE_EQ(wrap_angle(kPi), kPi);
  EXPECT_DOUBLE_EQ(wrap_angle(-kPi), kPi);
  EXPECT_NEAR(wrap_angle(3.0 * kPi / 2.0), -kPi / 2.0, 1e-12);
  EXPECT_NEAR(wrap_angle(-7.0), -7.0 + 2.0 * kPi, 1e-12);
  EXPECT_EQ(wrap_angle(NAN), 0.0);
}

}  // namespace
}  // namespace swerve
