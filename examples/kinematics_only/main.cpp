// Kinematics only, the way a WPILib swerve program uses it: each 20 ms cycle a field-relative
// driver command goes through inverse kinematics, each module is optimised against its measured
// angle (never steer more than 90 deg), the set is desaturated to the drive limit, and the module
// states are sent. Odometry integrates the wheel readings back into a pose. The "drives" here are
// ideal (they reach each command within the cycle), so the pose must follow the commanded motion.
//
//   swerve_kinematics_only   (prints the pose after 4 s and the fastest commanded module)
#include <algorithm>
#include <cmath>
#include <iostream>
#include <optional>

#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/odometry.hpp"
#include "swerve/kinematics/se2.hpp"

int main() {
  using swerve::ModuleState;
  constexpr double kPeriod = 0.02;  // s, the robot loop
  swerve::ModuleLimits limits;
  limits.max_drive_speed = 4.5;  // m/s: give your module's limit (the default is 2 m/s)
  const swerve::Kinematics kinematics(swerve::ModuleLayout::rectangle(0.6, 0.5, 0.05, limits));
  const int n = kinematics.size();

  swerve::ModuleStates measured(n);    // what the module encoders report (angle, speed)
  swerve::ModulePositions wheels(n);   // cumulative wheel distance and angle, for odometry
  swerve::Odometry odometry(kinematics, wheels);
  double fastest_command = 0.0;

  for (int cycle = 0; cycle < 200; ++cycle) {
    // The driver: 1 m/s along the field's x axis for 2 s, then along y, spinning at 0.5 rad/s.
    const bool first_leg = cycle < 100;
    const Eigen::Vector3d twist_world(first_leg ? 1.0 : 0.0, first_leg ? 0.0 : 1.0, 0.5);
    const double heading_world = odometry.pose_world().z();
    // Field-relative to robot-relative, then discretised so that holding it for one period ends
    // where the command says (WPILib's ChassisSpeeds.discretize).
    Eigen::Vector3d twist_body;
    swerve::discretize(swerve::twist_world_to_body(twist_world, heading_world), kPeriod, &twist_body);

    const std::optional<swerve::ModuleStates> desired = kinematics.inverse(twist_body);
    if (!desired) {
      std::cerr << "inverse kinematics refused the twist\n";
      return 1;
    }
    swerve::ModuleStates commands = *desired;
    for (int i = 0; i < n; ++i) commands[i] = swerve::optimize_module(commands[i], measured[i].angle);
    const swerve::KinematicsStatus status =
        swerve::Kinematics::desaturate(kinematics.layout().limits().max_drive_speed, &commands);
    if (status != swerve::KinematicsStatus::kOk) {
      std::cerr << "desaturate: " << swerve::to_string(status) << "\n";
      return 1;
    }

    // "Send" the states: ideal drives reach them within the cycle; the encoders report them back.
    for (int i = 0; i < n; ++i) {
      fastest_command = std::max(fastest_command, std::abs(commands[i].speed));
      measured[i] = commands[i];
      wheels[i].distance += commands[i].speed * kPeriod;
      wheels[i].angle = commands[i].angle;
    }
    odometry.update(wheels);
  }

  const Eigen::Vector3d& pose = odometry.pose_world();
  std::cout << "kinematics only: pose after 4 s (" << pose.x() << ", " << pose.y() << ", " << pose.z()
            << "), fastest module command " << fastest_command << " m/s\n";
  // 2 m along x, then 2 m along y, turning 2 rad: the odometry closes the loop on the commands.
  const bool followed = std::abs(pose.x() - 2.0) < 1e-6 && std::abs(pose.y() - 2.0) < 1e-6 &&
                        std::abs(pose.z() - 2.0) < 1e-6;
  return followed ? 0 : 1;
}
