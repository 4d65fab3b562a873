// The per-cycle kinematics calls allocate nothing after construction (counted, not timed).
#include <gtest/gtest.h>

#include "support/allocation_counter.hpp"
#include "swerve/kinematics/icr.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/odometry.hpp"
#include "swerve/kinematics/se2.hpp"
#include "swerve/kinematics/setpoint_generator.hpp"

namespace swerve {
namespace {

TEST(KinematicsRealTime, PerCycleCallsDoNotAllocate) {
  if (!testing::AllocationCounter::available()) GTEST_SKIP() << "allocation counting unavailable (a sanitizer owns malloc)";
  for (const ModuleLayout& layout : {ModuleLayout::rectangle(0.6, 0.4, 0.05), ModuleLayout::multi_axle(4, 0.4, 0.7, 0.05),
                                     ModuleLayout::two_module(0.3, 0.5, 0.05)}) {
    const int n = layout.size();
    const Kinematics kinematics(layout);
    ModuleHeadingMemory memory(n);
    ModuleStates states(n), measured(n);
    ModuleWeights weights(n, 1.0);
    ModulePositions wheels(n);
    ModuleAccelerations accelerations(n);
    Odometry odometry(kinematics, wheels);
    const SetpointGenerator generator(kinematics, ProfileLimits{});
    Setpoint setpoint = generator.stopped();
    Setpoint next = setpoint;
    IcrEstimate icr;
    Eigen::Vector3d twist;
    const testing::AllocationCounter counter;
    for (int cycle = 0; cycle < 20; ++cycle) {
      const Eigen::Vector3d command(0.5 + 0.01 * cycle, -0.2, 0.8);
      kinematics.command(command, &memory, &states, {0.1, 0.0}, &measured);
      kinematics.command(command, &memory, &states);
      kinematics.forward(states, &twist);
      kinematics.forward(states, weights, &twist);
      kinematics.second_order(command, {0.1, 0.2, 0.3}, states, &accelerations);
      kinematics.chassis_acceleration(states, accelerations, &twist);
      kinematics.desaturate_twist(command, 1.0, DesaturationPriority::kKeepRotation, &twist);
      discretize(command, 0.02, &twist);
      for (int i = 0; i < n; ++i) wheels[i] = ModulePosition{wheels[i].distance + 0.01, states[i].angle};
      odometry.update(wheels);
      odometry.update(wheels, 0.01 * cycle);
      estimate_icr(kinematics, states, &icr);
      generator.step(setpoint, command, 0.02, &next);
      setpoint = next;
      kinematics.command({NAN, 0.0, 0.0}, &memory, &states);  // error paths too
    }
    EXPECT_EQ(counter.count(), 0) << n << " modules";
  }
}

}  // namespace
}  // namespace swerve
