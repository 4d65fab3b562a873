// SetpointGenerator: every step within the steering-rate and acceleration limits, modules
// consistent with the chassis twist, convergence, stop-then-resteer, pre-steer, low jerk.
#include "swerve/kinematics/setpoint_generator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kinematics/test_layouts.hpp"
#include "swerve/kinematics/icr.hpp"

namespace swerve {
namespace {

constexpr double kDt = 0.02;

ProfileLimits test_limits(double jerk = 0.0) {
  ProfileLimits limits;
  limits.max_drive_speed = 3.0;
  limits.max_drive_acceleration = 4.0;
  limits.max_steering_rate = 8.0;
  limits.max_drive_jerk = jerk;
  return limits;
}

// Checks one step against the limits and, for body-first, against inverse kinematics.
void expect_step_feasible(const SetpointGenerator& generator, const Setpoint& before, const Setpoint& after) {
  const ProfileLimits& limits = generator.limits();
  const double threshold = generator.kinematics().options().hold_speed_threshold;
  ModuleStates ik;
  generator.kinematics().inverse(after.twist_body, &ik);
  for (int i = 0; i < after.modules.size(); ++i) {
    EXPECT_LE(std::abs(wrap_angle(after.modules[i].angle - before.modules[i].angle)),
              limits.max_steering_rate * kDt + 1e-9)
        << "module " << i;
    EXPECT_LE(std::abs(after.modules[i].speed - before.modules[i].speed),
              limits.max_drive_acceleration * kDt + 1e-9)
        << "module " << i;
    if (generator.mode() == ProfileMode::kBodyFirst && ik[i].speed >= threshold) {
      // Consistent: the module drives exactly its inverse-kinematics velocity (maybe reversed).
      EXPECT_NEAR(std::abs(after.modules[i].speed), ik[i].speed, 1e-9);
      EXPECT_NEAR(std::sin(after.modules[i].angle - ik[i].angle), 0.0, 1e-9);
    }
  }
}

TEST(SetpointGenerator, EveryStepRespectsLimitsAndStaysConsistentForTwoToEightModules) {
  std::mt19937 rng(31);
  for (const auto& [name, layout] : testing::layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const SetpointGenerator generator(Kinematics(layout), test_limits());
    Setpoint setpoint = generator.stopped();
    for (int leg = 0; leg < 6; ++leg) {
      const Eigen::Vector3d target = testing::random_twist(rng);
      Eigen::Vector3d feasible_target;
      generator.kinematics().desaturate_twist(target, 3.0, DesaturationPriority::kProportional, &feasible_target);
      int step = 0;
      for (; step < 400; ++step) {
        Setpoint next;
        ASSERT_EQ(generator.step(setpoint, target, kDt, &next), KinematicsStatus::kOk);
        expect_step_feasible(generator, setpoint, next);
        setpoint = next;
        if ((setpoint.twist_body - feasible_target).norm() < 1e-12) break;
      }
      EXPECT_LT(step, 400) << "leg " << leg << " did not converge";
    }
  }
}

TEST(SetpointGenerator, AStoppedRobotTurnsItsWheelsBeforeItDrives) {
  const SetpointGenerator generator(Kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05)), test_limits());
  Setpoint setpoint = generator.stopped();
  const Eigen::Vector3d strafe(0.0, 1.0, 0.0);
  // pi/2 at 8 rad/s takes ~0.2 s = 10 steps; the robot barely moves meanwhile.
  for (int step = 0; step < 9; ++step) {
    Setpoint next;
    ASSERT_EQ(generator.step(setpoint, strafe, kDt, &next), KinematicsStatus::kOk);
    expect_step_feasible(generator, setpoint, next);
    EXPECT_LT(next.twist_body.norm(), 2e-3) << step;
    EXPECT_NEAR(next.modules[0].angle, (step + 1) * 8.0 * kDt, 1e-9);
    setpoint = next;
  }
  for (int step = 0; step < 60; ++step) {
    Setpoint next;
    generator.step(setpoint, strafe, kDt, &next);
    setpoint = next;
  }
  EXPECT_NEAR((setpoint.twist_body - strafe).norm(), 0.0, 1e-12);
}

TEST(SetpointGenerator, ReversingEveryModuleStopsFirstThenResteers) {
  const SetpointGenerator generator(Kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05)), test_limits());
  ModuleStates angles(4);
  Setpoint setpoint = generator.stopped(&angles);
  setpoint.twist_body = {1.0, 0.0, 0.0};
  for (int i = 0; i < 4; ++i) setpoint.modules[i].speed = 1.0;
  const Eigen::Vector3d target(-1.0, -0.6, 0.0);  // every module must reverse
  bool stopped = false;
  for (int step = 0; step < 200; ++step) {
    Setpoint next;
    ASSERT_EQ(generator.step(setpoint, target, kDt, &next), KinematicsStatus::kOk);
    expect_step_feasible(generator, setpoint, next);
    if (!stopped) {
      // Braking along the current headings: no steering while moving forwards.
      for (int i = 0; i < 4; ++i) EXPECT_EQ(next.modules[i].angle, 0.0) << step;
      EXPECT_GE(next.twist_body.x(), -1e-12);
      EXPECT_NEAR(next.twist_body.y(), 0.0, 1e-12);
      stopped = next.twist_body.norm() < 1e-12;
    }
    setpoint = next;
  }
  EXPECT_TRUE(stopped);
  // The target is within the 3 m/s drive limit (fastest module ~1.17 m/s), so desaturation leaves
  // it unchanged and the generator must end exactly on it.
  Eigen::Vector3d feasible;
  ASSERT_EQ(
      generator.kinematics().desaturate_twist(target, 3.0, DesaturationPriority::kProportional, &feasible),
      KinematicsStatus::kOk);
  EXPECT_EQ(feasible, target);
  EXPECT_NEAR((setpoint.twist_body - feasible).norm(), 0.0, 1e-12);
}

// Largest per-step change of any module's drive acceleration over a speed-up from rest.
double largest_acceleration_jump(double jerk, const Eigen::Vector3d& target) {
  const SetpointGenerator generator(Kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05)), test_limits(jerk));
  ModuleStates angles;
  generator.kinematics().inverse(target, &angles);  // wheels already aligned
  Setpoint setpoint = generator.stopped(&angles);
  double jump = 0.0;
  for (int step = 0; step < 300; ++step) {
    Setpoint next;
    generator.step(setpoint, target, kDt, &next);
    for (int i = 0; i < 4; ++i) {
      jump = std::max(jump, std::abs(next.drive_acceleration[i] - setpoint.drive_acceleration[i]));
    }
    setpoint = next;
  }
  EXPECT_NEAR((setpoint.twist_body - target).norm(), 0.0, 1e-9);
  return jump;
}

TEST(SetpointGenerator, LowJerkProfileRampsAccelerationUpAndDown) {
  const double jerk = 20.0;
  for (const Eigen::Vector3d& target : {Eigen::Vector3d(2.0, 0.0, 0.0), Eigen::Vector3d(1.0, 0.5, 1.5)}) {
    EXPECT_GE(largest_acceleration_jump(0.0, target), 4.0 - 1e-6);  // plain profile: a step to the limit
    EXPECT_LE(largest_acceleration_jump(jerk, target), 2.0 * jerk * kDt + 1e-9);
  }
}

TEST(SetpointGenerator, ModuleFirstModeRespectsLimitsButLosesConsistency) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  const SetpointGenerator body_first(kinematics, test_limits());
  const SetpointGenerator module_first(kinematics, test_limits(), ProfileMode::kModuleFirst);
  ModuleStates angles;
  kinematics.inverse({1.0, 0.0, 0.0}, &angles);
  Setpoint a = body_first.stopped(&angles);
  a.twist_body = {1.0, 0.0, 0.0};
  for (int i = 0; i < 4; ++i) a.modules[i].speed = 1.0;
  Setpoint b = a;
  double worst_body = 0.0;
  double worst_module = 0.0;
  for (int step = 0; step < 30; ++step) {
    Setpoint next_a, next_b;
    body_first.step(a, {0.3, 0.9, 1.5}, kDt, &next_a);
    ASSERT_EQ(module_first.step(b, {0.3, 0.9, 1.5}, kDt, &next_b), KinematicsStatus::kOk);
    expect_step_feasible(module_first, b, next_b);
    IcrEstimate icr;
    estimate_icr(kinematics, next_a.modules, &icr);
    worst_body = std::max(worst_body, icr.residual);
    estimate_icr(kinematics, next_b.modules, &icr);
    worst_module = std::max(worst_module, icr.residual);
    a = next_a;
    b = next_b;
  }
  EXPECT_LT(worst_body, 1e-9);
  EXPECT_GT(worst_module, 1e-2);
}

TEST(SetpointGenerator, BadInputIsAStatusAndAStandstillSetpoint) {
  const SetpointGenerator generator(Kinematics(ModuleLayout::triangle(0.4, 0.05)), test_limits());
  Setpoint setpoint = generator.stopped();
  setpoint.modules[1].angle = 0.4;
  Setpoint next;
  EXPECT_EQ(generator.step(setpoint, {1.0, 0.0, 0.0}, -kDt, &next), KinematicsStatus::kInvalidDt);
  EXPECT_EQ(next.twist_body, Eigen::Vector3d::Zero());
  EXPECT_DOUBLE_EQ(next.modules[1].angle, 0.4);
  EXPECT_EQ(generator.step(setpoint, {NAN, 0.0, 0.0}, kDt, &next), KinematicsStatus::kNonFiniteInput);
  Setpoint wrong = setpoint;
  wrong.modules.resize(2);
  EXPECT_EQ(generator.step(wrong, {1.0, 0.0, 0.0}, kDt, &next), KinematicsStatus::kWrongModuleCount);
  ProfileLimits negative = test_limits();
  negative.max_steering_rate = -1.0;
  try {
    SetpointGenerator(Kinematics(ModuleLayout::triangle(0.4, 0.05)), negative);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_NE(std::string(error.what()).find("max_steering_rate = -1"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace swerve
