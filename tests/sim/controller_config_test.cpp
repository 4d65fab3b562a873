// The controller YAML's stale_measurement block: read into ControllerOptions, and bad values named
// with the key path. (In sim_tests: the controller loader lives in the scenarios library.)
#include "swerve/config/controller_config.hpp"

#include <gtest/gtest.h>

#include <string>

#include "swerve/config/config_error.hpp"
#include "swerve/config/config_node.hpp"

namespace swerve {
namespace {

ControllerConfig load(const std::string& stale_block) {
  const std::string yaml = "controller:\n  name: c\n  type: wear_mpc\n" + stale_block;
  const config::ConfigNode root = config::ConfigNode::parse(yaml, "c.yaml");
  ControllerConfig config = load_controller_config(root.child("controller"));
  root.expect_all_read();  // as the file loaders do: an unknown key is an error
  return config;
}

TEST(ControllerConfig, ReadsTheStaleMeasurementLimits) {
  const ControllerConfig c = load("  stale_measurement: {max_age: 0.25, frozen_cycles: 5, moving_speed: 0.02}\n");
  EXPECT_DOUBLE_EQ(c.mpc.stale_measurement.max_age, 0.25);
  EXPECT_EQ(c.mpc.stale_measurement.frozen_cycles, 5);
  EXPECT_DOUBLE_EQ(c.mpc.stale_measurement.moving_speed, 0.02);
  const ControllerConfig defaults = load("");
  EXPECT_DOUBLE_EQ(defaults.mpc.stale_measurement.max_age, StalenessOptions{}.max_age);
  EXPECT_EQ(defaults.mpc.stale_measurement.frozen_cycles, StalenessOptions{}.frozen_cycles);
}

TEST(ControllerConfig, RejectsBadStaleMeasurementLimitsNamingTheKeyPath) {
  const struct {
    const char* block;
    const char* key;
  } cases[] = {{"  stale_measurement: {max_age: 0}\n", "controller.stale_measurement.max_age"},
               {"  stale_measurement: {max_age: .nan}\n", "controller.stale_measurement.max_age"},
               {"  stale_measurement: {frozen_cycles: 1}\n", "controller.stale_measurement.frozen_cycles"},
               {"  stale_measurement: {moving_speed: -1}\n", "controller.stale_measurement.moving_speed"},
               {"  stale_measurement: {max_agee: 1}\n", "controller.stale_measurement.max_agee"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.block);
    try {
      load(c.block);
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("c.yaml"), std::string::npos) << message;
      EXPECT_NE(message.find(c.key), std::string::npos) << message;
    }
  }
}

TEST(StalenessOptions, ValidateNamesTheField) {
  StalenessOptions o;
  o.frozen_cycles = 1;
  try {
    o.validate();
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("frozen_cycles"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace swerve
