// Module faults (kinematics/module_faults.hpp): the words for each fault, and the command map with
// a stuck steering against hand-derived commands: no steering rate, and the wheel rolling with the
// contact velocity's component along the held angle, the healthy modules unchanged.
#include "swerve/kinematics/module_faults.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "swerve/core/config_error.hpp"
#include "swerve/kinematics/module_commands.hpp"

namespace swerve {
namespace {

TEST(ModuleFault, EachFaultReadsBackFromItsWord) {
  for (ModuleFault fault : {ModuleFault::kNone, ModuleFault::kStuckSteering}) {
    EXPECT_EQ(module_fault_from_string(to_string(fault), "faults[0].kind"), fault);
  }
}

TEST(ModuleFault, AnUnknownWordIsRefusedNamingTheFieldAndTheWord) {
  try {
    module_fault_from_string("stuck_drive", "simulator.faults[1].kind");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("simulator.faults[1].kind"), std::string::npos) << message;
    EXPECT_NE(message.find("stuck_drive"), std::string::npos) << message;
  }
}

TEST(ModuleFault, SteeringStuckReadsOnlyModulesInRange) {
  ModuleFaults faults(3, ModuleFault::kNone);
  faults[1] = ModuleFault::kStuckSteering;
  EXPECT_FALSE(steering_stuck(&faults, 0));
  EXPECT_TRUE(steering_stuck(&faults, 1));
  EXPECT_FALSE(steering_stuck(&faults, 3));
  EXPECT_FALSE(steering_stuck(&faults, -1));
  EXPECT_FALSE(steering_stuck(nullptr, 1));
  EXPECT_TRUE(any_fault(faults));
  EXPECT_FALSE(any_fault(ModuleFaults(3, ModuleFault::kNone)));
}

TEST(ModuleCommandsWithAFault, AStuckModuleGetsNoRateAndRollsAlongItsAngleWhileTheOthersAreUnchanged) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  const Eigen::Vector3d twist(1.0, 0.5, 0.2);
  const Eigen::VectorXd angles = Eigen::VectorXd::Constant(4, 0.3);
  ModuleCommandRule rule;
  Eigen::VectorXd healthy(8), faulty(8);
  module_commands<double>(layout, twist, angles, 0.05, rule, healthy);
  ModuleFaults faults(4, ModuleFault::kNone);
  faults[2] = ModuleFault::kStuckSteering;
  rule.faults = &faults;
  module_commands<double>(layout, twist, angles, 0.05, rule, faulty);
  // By hand: module 2's contact velocity is (vx - r y, vy + r x); its wheel at 0.3 rad rolls at
  // the component along (cos 0.3, sin 0.3), over the wheel radius.
  const Eigen::Vector2d r = layout.position_body(2);
  const double vx = 1.0 - 0.2 * r.y(), vy = 0.5 + 0.2 * r.x();
  EXPECT_EQ(faulty[4], 0.0);
  EXPECT_NEAR(faulty[5], (std::cos(0.3) * vx + std::sin(0.3) * vy) / 0.05, 1e-12);
  EXPECT_NE(healthy[4], 0.0);  // healthy, the module would have steered
  for (int i : {0, 1, 3}) {
    EXPECT_EQ(faulty[2 * i], healthy[2 * i]) << "module " << i;
    EXPECT_EQ(faulty[2 * i + 1], healthy[2 * i + 1]) << "module " << i;
  }
}

TEST(DescribeLostMotions, NamesEachStuckModuleAndItsAngleAndIsEmptyWithoutFaults) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  ModuleFaults faults(4, ModuleFault::kNone);
  ModuleArray<double> angles(4, 0.0);
  EXPECT_EQ(describe_lost_motions(layout, faults, angles), "");
  faults[3] = ModuleFault::kStuckSteering;
  angles[3] = 0.25;
  const std::string text = describe_lost_motions(layout, faults, angles);
  const Eigen::Vector2d& at = layout.position_body(3);
  std::ostringstream where;
  where << "module 3 at (" << at.x() << ", " << at.y() << ") m stuck at 0.25 rad";
  EXPECT_NE(text.find(where.str()), std::string::npos) << text;
  EXPECT_EQ(text.find("module 0"), std::string::npos) << text;
}

}  // namespace
}  // namespace swerve
