// VehicleParams: static normal loads by hand (equal shares for symmetric layouts, the lever rule
// for a caster robot), and validation that names each bad field and its value.
#include "swerve/models/vehicle_params.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "support/model_fixtures.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

TEST(VehicleParams, SymmetricLayoutsShareTheWeightEqually) {
  // docs/paper.md, assumption 2: F_N = m g / n on every wheel of a symmetric layout.
  for (const auto& named : testing::test_layouts()) {
    const VehicleParams params = testing::make_params(named.layout);
    const auto loads = params.static_normal_loads();
    ASSERT_EQ(static_cast<int>(loads.size()), named.layout.size());
    for (double load : loads) {
      EXPECT_NEAR(load, params.mass * params.gravity / named.layout.size(), 1e-9) << named.name;
    }
  }
}

TEST(VehicleParams, CasterRobotLoadsFollowTheLeverRule) {
  const VehicleParams params = testing::make_caster_params();
  const auto loads = params.static_normal_loads();
  ASSERT_EQ(loads.size(), 3u);
  const double weight = params.mass * params.gravity;
  // Modules at x = 0.3, caster at x = -0.35, CoM at x = 0.05: the modules carry
  // weight (0.05 + 0.35) / 0.65, split equally; the caster the rest.
  EXPECT_NEAR(loads[0], weight * 0.4 / 0.65 / 2.0, 1e-9);
  EXPECT_NEAR(loads[1], weight * 0.4 / 0.65 / 2.0, 1e-9);
  EXPECT_NEAR(loads[2], weight * 0.25 / 0.65, 1e-9);
}

TEST(VehicleParams, OffCentreMassShiftsLoadButKeepsEquilibrium) {
  VehicleParams params = testing::make_params(ModuleLayout::rectangle(1.0, 0.6, 0.1));
  params.center_of_mass_body = {0.1, -0.05};
  const auto loads = params.static_normal_loads();
  double sum = 0.0;
  double moment_x = 0.0;
  double moment_y = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d arm = params.layout.position_body(i) - params.center_of_mass_body;
    sum += loads[static_cast<std::size_t>(i)];
    moment_x += loads[static_cast<std::size_t>(i)] * arm.x();
    moment_y += loads[static_cast<std::size_t>(i)] * arm.y();
  }
  EXPECT_NEAR(sum, params.mass * params.gravity, 1e-9);
  EXPECT_NEAR(moment_x, 0.0, 1e-9);
  EXPECT_NEAR(moment_y, 0.0, 1e-9);
  EXPECT_GT(loads[1], loads[2]);  // front right carries more than rear left
}

void expect_rejected(const std::function<void(VehicleParams&)>& edit, const std::string& expected) {
  VehicleParams params = testing::make_params(4);
  edit(params);
  try {
    params.validate();
    ADD_FAILURE() << "accepted: " << expected;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(VehicleParams, RejectsEachBadFieldNamingItAndItsValue) {
  expect_rejected([](VehicleParams& p) { p.mass = 0.0; }, "VehicleParams.mass = 0: must be finite and > 0");
  expect_rejected([](VehicleParams& p) { p.mass = std::nan(""); }, "VehicleParams.mass = nan");
  expect_rejected([](VehicleParams& p) { p.yaw_inertia = -2.0; }, "VehicleParams.yaw_inertia = -2");
  expect_rejected([](VehicleParams& p) { p.gravity = INFINITY; }, "VehicleParams.gravity = inf");
  expect_rejected([](VehicleParams& p) { p.center_of_mass_body.x() = std::nan(""); }, "VehicleParams.center_of_mass");
  expect_rejected([](VehicleParams& p) { p.cog_height = -0.1; }, "VehicleParams.cog_height = -0.1");
  expect_rejected([](VehicleParams& p) { p.actuators.steering_time_constant = 0.0; },
                  "VehicleParams.actuators.steering_time_constant = 0");
  expect_rejected([](VehicleParams& p) { p.actuators.drive_time_constant = -1.0; },
                  "VehicleParams.actuators.drive_time_constant = -1");
  expect_rejected([](VehicleParams& p) { p.plant.relaxation_length = -0.1; },
                  "VehicleParams.plant.relaxation_length = -0.1");
  expect_rejected([](VehicleParams& p) { p.plant.load_transfer = true; }, "needs cog_height");
  expect_rejected([](VehicleParams& p) { p.tire.mu = -0.8; }, "MagicFormulaParams.mu = -0.8");
  expect_rejected([](VehicleParams& p) { p.wear.coefficient = 0.0; }, "WearParams.coefficient = 0");
  expect_rejected([](VehicleParams& p) { p.center_of_mass_body = {2.0, 0.0}; },
                  "VehicleParams.center_of_mass = [2, 0]: lies outside the support");
  expect_rejected(
      [](VehicleParams& p) {
        CasterParams c;
        c.position_body = {0.4, 0.3};
        p.casters.push_back(c);
      },
      "VehicleParams.casters[0].position = [0.4, 0.3]: coincides with modules[0]");
  expect_rejected(
      [](VehicleParams& p) {
        CasterParams c;
        c.position_body = {-1.0, 0.0};
        c.rolling_resistance = -0.1;
        p.casters.push_back(c);
      },
      "VehicleParams.casters[0].rolling_resistance = -0.1");
}

TEST(VehicleParams, TwoModulesNeedTheCentreOfMassOnTheirLine) {
  VehicleParams params = testing::make_params(ModuleLayout({{0.0, 0.3}, {0.0, -0.3}}, 0.1));
  EXPECT_NO_THROW(params.validate());
  params.center_of_mass_body = {0.1, 0.0};
  try {
    params.validate();
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("off the line through all contacts"), std::string::npos) << e.what();
  }
}

TEST(VehicleParams, LayoutErrorsComeFromModuleLayout) {
  EXPECT_THROW(ModuleLayout({{0.0, 0.0}}, 0.1), ConfigError);                 // < 2 modules
  EXPECT_THROW(ModuleLayout({{0.0, 0.0}, {0.0, 0.0}}, 0.1), ConfigError);     // same point
  EXPECT_THROW(ModuleLayout({{0.0, 0.3}, {0.0, -0.3}}, 0.0), ConfigError);    // wheel radius
}

}  // namespace
}  // namespace swerve
