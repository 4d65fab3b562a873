// ModuleLayout: builder geometry by hand, validation messages naming module and value, YAML loading.
#include "swerve/app/kinematics_config.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/kinematics/module_state.hpp"
#include "support/config_errors.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace swerve {
namespace {

void expect_position(const ModuleLayout& layout, int module, double x, double y) {
  EXPECT_NEAR(layout.position_body(module).x(), x, 1e-12) << "module " << module;
  EXPECT_NEAR(layout.position_body(module).y(), y, 1e-12) << "module " << module;
}

TEST(ModuleLayout, RectangleIsFrontLeftFrontRightRearLeftRearRight) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05);
  ASSERT_EQ(layout.size(), 4);
  expect_position(layout, 0, 0.3, 0.2);
  expect_position(layout, 1, 0.3, -0.2);
  expect_position(layout, 2, -0.3, 0.2);
  expect_position(layout, 3, -0.3, -0.2);
  EXPECT_DOUBLE_EQ(layout.wheel_radius(), 0.05);
}

TEST(ModuleLayout, TriangleStartsAheadAndTurnsCounterClockwise) {
  const ModuleLayout layout = ModuleLayout::triangle(0.4, 0.05);
  ASSERT_EQ(layout.size(), 3);
  expect_position(layout, 0, 0.4, 0.0);
  expect_position(layout, 1, -0.2, 0.4 * std::sqrt(3.0) / 2.0);
  expect_position(layout, 2, -0.2, -0.4 * std::sqrt(3.0) / 2.0);
}

TEST(ModuleLayout, MultiAxleIsCentredFrontAxleFirstLeftThenRight) {
  const ModuleLayout layout = ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05);
  ASSERT_EQ(layout.size(), 6);
  expect_position(layout, 0, 0.5, 0.3);
  expect_position(layout, 1, 0.5, -0.3);
  expect_position(layout, 2, 0.0, 0.3);
  expect_position(layout, 5, -0.5, -0.3);
}

TEST(ModuleLayout, TwoModuleLayoutPutsTheSteeredPairSideBySide) {
  const ModuleLayout layout = ModuleLayout::two_module(0.3, 0.5, 0.05);
  ASSERT_EQ(layout.size(), 2);
  expect_position(layout, 0, 0.3, 0.25);
  expect_position(layout, 1, 0.3, -0.25);
}

TEST(ModuleLayout, RecenteredMeasuresModulesFromTheNewReferencePoint) {
  const ModuleLayout layout = ModuleLayout::rectangle(0.6, 0.4, 0.05).recentered({0.1, -0.05});
  expect_position(layout, 0, 0.2, 0.25);
  expect_position(layout, 3, -0.4, -0.15);
}

TEST(ModuleLayout, FewerThanTwoModulesIsRejected) {
  const std::string message = testing::config_error_of([] { ModuleLayout({{0.0, 0.0}}, 0.05); });
  EXPECT_NE(message.find("ModuleLayout.modules = 1"), std::string::npos) << message;
}

TEST(ModuleLayout, MoreModulesThanTheKinematicsSupportIsRejected) {
  // kMaxModules sizes every real-time buffer: a layout past it must fail here, where a config
  // loader sees it, not later when a Kinematics or controller is built.
  EXPECT_NO_THROW(ModuleLayout::multi_axle(kMaxModules / 2, 0.3, 0.6, 0.05));
  const std::string message = testing::config_error_of([] { ModuleLayout::multi_axle(kMaxModules / 2 + 1, 0.3, 0.6, 0.05); });
  EXPECT_NE(message.find("ModuleLayout.modules = 18: at most 16 modules are supported"), std::string::npos) << message;
}

TEST(ModuleLayout, CoincidentModulesAreRejectedNamingBothModules) {
  const std::string message = testing::config_error_of([] { ModuleLayout({{0.3, 0.2}, {-0.3, 0.2}, {0.3, 0.2}}, 0.05); });
  EXPECT_NE(message.find("modules[2].position"), std::string::npos) << message;
  EXPECT_NE(message.find("0.3"), std::string::npos) << message;
  EXPECT_NE(message.find("coincides with modules[0]"), std::string::npos) << message;
}

TEST(ModuleLayout, NonFinitePositionIsRejectedNamingTheModule) {
  const std::string message = testing::config_error_of([] { ModuleLayout({{0.3, 0.2}, {NAN, 0.2}}, 0.05); });
  EXPECT_NE(message.find("modules[1].position"), std::string::npos) << message;
}

TEST(ModuleLayout, BadWheelRadiusAndLimitsAreRejectedWithTheirValue) {
  EXPECT_NE(testing::config_error_of([] { ModuleLayout::rectangle(0.6, 0.4, -0.05); }).find("wheel_radius = -0.05"),
            std::string::npos);
  ModuleLimits limits;
  limits.max_drive_acceleration = -1.0;
  EXPECT_NE(testing::config_error_of([&] { ModuleLayout::rectangle(0.6, 0.4, 0.05, limits); })
                .find("max_drive_acceleration = -1"),
            std::string::npos);
  EXPECT_THROW(ModuleLayout::multi_axle(0, 0.5, 0.6, 0.05), ConfigError);
  EXPECT_THROW(ModuleLayout::rectangle(0.0, 0.4, 0.05), ConfigError);
}

TEST(ModuleLayout, LoadsFromAVehicleYamlSection) {
  const auto root = config::ConfigNode::parse(
      "vehicle:\n  wheel_radius: 0.06\n  modules:\n    - {position: [0.4, 0.3]}\n    - {position: [0.4, -0.3]}\n"
      "    - {position: [-0.4, 0.0]}\n  limits: {drive_speed: 3.0, steering_rate: 6.0, steering_angle: [-3.0, 3.0]}\n",
      "configs/vehicles/test.yaml");
  const ModuleLayout layout = load_module_layout(root.child("vehicle"));
  EXPECT_NO_THROW(root.expect_all_read());
  ASSERT_EQ(layout.size(), 3);
  expect_position(layout, 2, -0.4, 0.0);
  EXPECT_DOUBLE_EQ(layout.wheel_radius(), 0.06);
  EXPECT_DOUBLE_EQ(layout.limits().max_drive_speed, 3.0);
  EXPECT_DOUBLE_EQ(layout.limits().max_steering_rate, 6.0);
  EXPECT_DOUBLE_EQ(layout.limits().max_drive_acceleration, ModuleLimits{}.max_drive_acceleration);
  EXPECT_TRUE(layout.limits().has_steering_end_stops());
}

TEST(ModuleLayout, YamlWithMoreModulesThanSupportedNamesFileAndKey) {
  std::string text = "vehicle:\n  wheel_radius: 0.06\n  modules:\n";
  for (int i = 0; i <= kMaxModules; ++i) text += "    - {position: [" + std::to_string(0.5 * i) + ", 0.3]}\n";
  const auto root = config::ConfigNode::parse(text, "configs/vehicles/long.yaml");
  const std::string message = testing::config_error_of([&] { load_module_layout(root.child("vehicle")); });
  EXPECT_EQ(message, "configs/vehicles/long.yaml: vehicle.modules = a list of 17: at most 16 modules are supported");
}

TEST(ModuleLayout, YamlErrorsNameFileKeyPathAndValue) {
  const auto root = config::ConfigNode::parse(
      "vehicle:\n  wheel_radius: 0.06\n  modules:\n    - {position: [0.4, 0.3]}\n    - {position: [0.4, 0.3]}\n",
      "configs/vehicles/bad.yaml");
  const std::string message = testing::config_error_of([&] { load_module_layout(root.child("vehicle")); });
  EXPECT_NE(message.find("configs/vehicles/bad.yaml: vehicle.modules[1].position"), std::string::npos) << message;
  EXPECT_NE(message.find("coincides with modules[0]"), std::string::npos) << message;

  const auto negative = config::ConfigNode::parse(
      "vehicle:\n  wheel_radius: 0.06\n  modules:\n    - {position: [0.4, 0.3]}\n    - {position: [0.4, -0.3]}\n"
      "  limits: {steering_rate: -2}\n",
      "v.yaml");
  const std::string limit_message = testing::config_error_of([&] { load_module_layout(negative.child("vehicle")); });
  EXPECT_NE(limit_message.find("vehicle.limits.steering_rate"), std::string::npos) << limit_message;
}

}  // namespace
}  // namespace swerve
