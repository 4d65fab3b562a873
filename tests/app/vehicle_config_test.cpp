// Loading `vehicle:` sections: every shipped configs/vehicles/*.yaml, the values of one by hand,
// defaults, and errors that name the file, the key path and the value.
#include "swerve/app/vehicle_config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "support/bound_edges.hpp"
#include "swerve/core/config_error.hpp"
#include "swerve/models/vehicle_model.hpp"

namespace swerve {
namespace {

const std::string kVehicles = std::string(SWERVE_SOURCE_DIR) + "/configs/vehicles/";

TEST(VehicleConfig, EveryShippedVehicleLoadsAndBuildsBothModels) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kVehicles)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const VehicleParams params = load_vehicle_config_file(entry.path().string());
    const VehicleModel<double> ideal(params, Fidelity::kIdeal);
    const VehicleModel<double> plant(params, Fidelity::kPlant);
    EXPECT_EQ(ideal.state_size(), 6 + params.layout.size());
    EXPECT_GE(plant.state_size(), ideal.state_size());
    ++count;
  }
  EXPECT_GE(count, 5);
}

TEST(VehicleConfig, PaperVehicleHasTheStatedNumbers) {
  const VehicleParams p = load_vehicle_config_file(kVehicles + "paper_ms_agv.yaml");
  EXPECT_EQ(p.name, "paper_ms_agv");
  EXPECT_EQ(p.layout.size(), 10);
  EXPECT_DOUBLE_EQ(p.mass, 800.0);
  EXPECT_DOUBLE_EQ(p.yaw_inertia, 2900.0);
  EXPECT_DOUBLE_EQ(p.layout.wheel_radius(), 0.325);
  EXPECT_DOUBLE_EQ(p.layout.position_body(0).x(), 2.08);
  EXPECT_DOUBLE_EQ(p.layout.position_body(9).y(), -0.845);
  EXPECT_NEAR(p.layout.limits().max_steering_angle, 1.5707963267948966, 1e-15);
  EXPECT_DOUBLE_EQ(p.layout.limits().max_steering_rate, 1.0);
  EXPECT_DOUBLE_EQ(p.tire.mu, 0.8);
  EXPECT_DOUBLE_EQ(p.tire.longitudinal.b, 10.0);
  EXPECT_DOUBLE_EQ(p.tire.lateral.c, 1.3);
  EXPECT_EQ(p.wear.model, WearModelKind::kFrictionalPower);
  for (double load : p.static_normal_loads()) EXPECT_NEAR(load, 800.0 * 9.81 / 10.0, 1e-9);
}

VehicleParams load_text(const std::string& body) {
  const config::ConfigNode root = config::ConfigNode::parse(body, "test.yaml");
  VehicleParams params = load_vehicle_config(root.child("vehicle"));
  root.expect_all_read();
  return params;
}

const char* kMinimal = R"(vehicle:
  name: minimal
  mass: 100
  yaw_inertia: 10
  wheel_radius: 0.1
  modules: [{position: [0.3, 0.2]}, {position: [0.3, -0.2]}, {position: [-0.3, 0.2]}, {position: [-0.3, -0.2]}]
  tire: {mu: 0.9, longitudinal: {B: 8, C: 1.6}, lateral: {B: 12, C: 1.2}}
)";

TEST(VehicleConfig, OptionalKeysTakeTheirDocumentedDefaults) {
  const VehicleParams p = load_text(kMinimal);
  EXPECT_EQ(p.center_of_mass_body, Eigen::Vector2d::Zero());
  EXPECT_FALSE(p.cog_height.has_value());
  EXPECT_DOUBLE_EQ(p.gravity, 9.81);
  EXPECT_TRUE(p.casters.empty());
  EXPECT_DOUBLE_EQ(p.actuators.steering_time_constant, 0.05);
  EXPECT_DOUBLE_EQ(p.tire.longitudinal.e, 0.0);
  EXPECT_EQ(p.tire.combined_slip, CombinedSlipMethod::kNormalizedSlip);
  EXPECT_DOUBLE_EQ(p.tire.slip_speed_epsilon, 0.05);
  EXPECT_TRUE(p.tire.smooth_slip);
  EXPECT_EQ(p.wear.model, WearModelKind::kFrictionalPower);
  EXPECT_DOUBLE_EQ(p.wear.coefficient, 1.0);
  EXPECT_TRUE(p.plant.actuator_lag);
  EXPECT_FALSE(p.plant.load_transfer);
}

void expect_error(const std::string& text, const std::string& expected) {
  try {
    load_text(text);
    ADD_FAILURE() << "accepted; expected: " << expected;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

std::string with(const std::string& from, const std::string& to) {
  std::string text = kMinimal;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(VehicleConfig, ErrorsNameFileKeyPathAndValue) {
  expect_error(with("mass: 100", "mass: -100"), "test.yaml: vehicle.mass = -100: must be > 0");
  expect_error(with("yaw_inertia: 10", "yaw_inertia: 0"), "test.yaml: vehicle.yaw_inertia = 0");
  expect_error(with("mu: 0.9", "mu: 0"), "vehicle.tire.mu = 0");
  expect_error(with("C: 1.2", "C: 2.2"), "vehicle.tire.lateral.C = 2.2");
  expect_error(with("B: 8", "B: -8"), "vehicle.tire.longitudinal.B = -8");
  expect_error(with("mass: 100", "mass: 100\n  masss: 3"), "vehicle.masss: unknown key");
  expect_error(with("mass: 100", "mass: 100\n  wear: {model: magic}"), "vehicle.wear.model");
  expect_error(with("mass: 100", "mass: 100\n  plant: {load_transfer: true}"),
               "vehicle.plant.load_transfer = true: needs vehicle.cog_height");
  expect_error(with("mass: 100", "mass: 100\n  center_of_mass: [1.0, 0.0]"),
               "test.yaml: vehicle: VehicleParams.center_of_mass = [1, 0]: lies outside the support");
  expect_error(with("mass: 100", "mass: 100\n  casters: [{position: [0.3, 0.2]}]"),
               "VehicleParams.casters[0].position = [0.3, 0.2]: coincides with modules[0]");
  expect_error(with("mass: 100", "mass: 100\n  tire2: {}"), "vehicle.tire2: unknown key");
  expect_error(with("  tire: {mu: 0.9, longitudinal: {B: 8, C: 1.6}, lateral: {B: 12, C: 1.2}}\n", ""),
               "vehicle.tire: required key is missing");
}

TEST(VehicleConfig, EachTireChannelMayHaveItsOwnMu) {
  const VehicleParams common = load_text(kMinimal);
  EXPECT_FALSE(common.tire.longitudinal.mu.has_value());
  EXPECT_DOUBLE_EQ(common.tire.mu_lateral(), 0.9);
  const VehicleParams one = load_text(with("lateral: {B: 12, C: 1.2}", "lateral: {B: 12, C: 1.2, mu: 0.6}"));
  EXPECT_DOUBLE_EQ(one.tire.mu_longitudinal(), 0.9);
  EXPECT_DOUBLE_EQ(one.tire.mu_lateral(), 0.6);
  // Both channels with their own: the common mu may be left out.
  const VehicleParams both = load_text(with("{mu: 0.9, longitudinal: {B: 8, C: 1.6}, lateral: {B: 12, C: 1.2}}",
                                            "{longitudinal: {B: 8, C: 1.6, mu: 1.1}, lateral: {B: 12, C: 1.2, mu: 0.7}}"));
  EXPECT_DOUBLE_EQ(both.tire.mu_longitudinal(), 1.1);
  EXPECT_DOUBLE_EQ(both.tire.mu_lateral(), 0.7);
}

TEST(VehicleConfig, ChannelMuErrorsNameTheKey) {
  expect_error(with("lateral: {B: 12, C: 1.2}", "lateral: {B: 12, C: 1.2, mu: -0.6}"),
               "vehicle.tire.lateral.mu = -0.6: must be > 0");
  expect_error(with("lateral: {B: 12, C: 1.2}", "lateral: {B: 12, C: 1.2, mu: grippy}"), "vehicle.tire.lateral.mu");
  // Only one channel with its own mu: the common one is still needed for the other.
  expect_error(with("{mu: 0.9, longitudinal: {B: 8, C: 1.6}, lateral: {B: 12, C: 1.2}}",
                    "{longitudinal: {B: 8, C: 1.6, mu: 1.1}, lateral: {B: 12, C: 1.2}}"),
               "vehicle.tire.mu: required key is missing");
}

TEST(VehicleConfig, MissingFileIsAClearError) {
  EXPECT_THROW(load_vehicle_config_file(kVehicles + "no_such_vehicle.yaml"), ConfigError);
}

// Each numeric rule of the vehicle's tables, just outside its bound: the loader (the key in its
// block of a minimal file) and validate() (of a vehicle built in code) both reject it.
template <typename Options, typename Set>
void expect_loader_and_validate_reject_the_same(const OptionFields<Options>& fields, const std::string& block,
                                                const Set& set_on_vehicle) {
  const VehicleParams minimal = load_text(kMinimal);
  for (const OptionField<Options>& field : fields) {
    const auto* real = std::get_if<double Options::*>(&field.member);
    if (real == nullptr) continue;
    for (const double value : testing::values_just_outside(field.bound)) {
      SCOPED_TRACE(std::string(field.name) + " = " + Bound::number(value));
      VehicleParams params = minimal;
      set_on_vehicle(params, *real, value);
      try {
        params.validate();
        ADD_FAILURE() << "validate() accepted it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(std::string(field.name) + " = "), std::string::npos) << e.what();
      }
      const std::string text =
          std::string(kMinimal) + "  " + block + ":\n    " + field.yaml_key() + ": " + Bound::number(value) + "\n";
      try {
        load_text(text);
        ADD_FAILURE() << "the loader accepted it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find(std::string(block) + "." + field.yaml_key()), std::string::npos)
            << e.what();
      }
    }
  }
}

TEST(VehicleConfig, TheLoaderAndValidateRejectTheSameValuesOfEveryVehicleTable) {
  expect_loader_and_validate_reject_the_same(ActuatorParams::fields(), "actuators",
                                             [](VehicleParams& p, double ActuatorParams::*m, double v) { p.actuators.*m = v; });
  expect_loader_and_validate_reject_the_same(PlantOptions::fields(), "plant",
                                             [](VehicleParams& p, double PlantOptions::*m, double v) { p.plant.*m = v; });
  expect_loader_and_validate_reject_the_same(WearParams::fields(), "wear",
                                             [](VehicleParams& p, double WearParams::*m, double v) { p.wear.*m = v; });
}

// The tire's tables the same way: each channel rule in the lateral channel of the minimal file
// and of a vehicle built in code, and the tire's own rules in its block.
TEST(VehicleConfig, TheLoaderAndValidateRejectTheSameTireValues) {
  const VehicleParams minimal = load_text(kMinimal);
  for (const OptionField<MagicFormulaCoefficients>& field : MagicFormulaCoefficients::fields()) {
    for (const double value : testing::values_just_outside(field.bound)) {
      SCOPED_TRACE(std::string(field.name) + " = " + Bound::number(value));
      VehicleParams params = minimal;
      if (const auto* real = std::get_if<double MagicFormulaCoefficients::*>(&field.member)) {
        params.tire.lateral.*(*real) = value;
      } else if (const auto* maybe = std::get_if<std::optional<double> MagicFormulaCoefficients::*>(&field.member)) {
        params.tire.lateral.*(*maybe) = value;
      } else {
        continue;
      }
      try {
        params.validate();
        ADD_FAILURE() << "validate() accepted it";
      } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("MagicFormulaParams.lateral." + std::string(field.name) + " = "),
                  std::string::npos)
            << e.what();
      }
      std::map<std::string, std::string> keys{{"B", "12"}, {"C", "1.2"}};
      keys[field.yaml_key()] = Bound::number(value);
      std::string channel = "lateral: {";
      for (const auto& [key, text] : keys) channel += (channel.back() == '{' ? "" : ", ") + key + ": " + text;
      expect_error(with("lateral: {B: 12, C: 1.2}", channel + "}"),
                   "vehicle.tire.lateral." + std::string(field.yaml_key()) + " = " + Bound::number(value));
    }
  }
  for (const OptionField<MagicFormulaParams>& field : MagicFormulaParams::fields()) {
    const auto* real = std::get_if<double MagicFormulaParams::*>(&field.member);
    if (real == nullptr) continue;
    for (const double value : testing::values_just_outside(field.bound)) {
      SCOPED_TRACE(std::string(field.name) + " = " + Bound::number(value));
      VehicleParams params = minimal;
      params.tire.*(*real) = value;
      EXPECT_THROW(params.validate(), ConfigError);
      const std::string key = field.yaml_key();
      const std::string entry = key + ": " + Bound::number(value);
      expect_error(key == "mu" ? with("mu: 0.9", entry) : with("tire: {", "tire: {" + entry + ", "),
                   "vehicle.tire." + key + " = " + Bound::number(value));
    }
  }
}

TEST(VehicleConfig, CogHeightIsCheckedByTheVehiclesTableWhenSet) {
  VehicleParams params = load_text(kMinimal);
  params.cog_height = -0.2;
  try {
    params.validate();
    ADD_FAILURE() << "validate() accepted it";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("VehicleParams.cog_height = -0.2: must be finite and > 0"), std::string::npos)
        << e.what();
  }
  expect_error(with("mass: 100", "mass: 100\n  cog_height: 0"), "vehicle.cog_height = 0: must be > 0");
  EXPECT_DOUBLE_EQ(load_text(with("mass: 100", "mass: 100\n  cog_height: 0.4")).cog_height.value_or(0.0), 0.4);
}

}  // namespace
}  // namespace swerve
