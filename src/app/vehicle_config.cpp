#include "swerve/app/vehicle_config.hpp"

#include "swerve/app/kinematics_config.hpp"
#include "swerve/app/option_reader.hpp"

namespace swerve {
namespace {

using config::ConfigNode;

MagicFormulaCoefficients load_channel(const ConfigNode& node) {
  MagicFormulaCoefficients k;
  (void)node.child("B");  // required, as is C
  (void)node.child("C");
  config::read_fields(node, MagicFormulaCoefficients::fields(), &k);
  return k;
}

MagicFormulaParams load_tire(const ConfigNode& node) {
  MagicFormulaParams tire;
  tire.longitudinal = load_channel(node.child("longitudinal"));
  tire.lateral = load_channel(node.child("lateral"));
  // The common mu serves every channel without its own; with both set it may be left out.
  const bool both_channels_have_mu = tire.longitudinal.mu && tire.lateral.mu;
  if (both_channels_have_mu && !node.has("mu")) {
    tire.mu = *tire.longitudinal.mu;  // unused: both channels have their own
  } else {
    (void)node.child("mu");  // "required key is missing"
  }
  config::read_fields(node, MagicFormulaParams::fields(), &tire);
  const std::string method =
      node.get_choice_or("combined_slip", {"none", "ellipse_cap", "normalized_slip"}, "normalized_slip");
  tire.combined_slip = method == "none"          ? CombinedSlipMethod::kNone
                       : method == "ellipse_cap" ? CombinedSlipMethod::kEllipseCap
                                                 : CombinedSlipMethod::kNormalizedSlip;
  return tire;
}

WearParams load_wear(const ConfigNode& node) {
  WearParams wear;
  const std::string model = node.get_choice_or("model", {"frictional_power", "archard"}, "frictional_power");
  wear.model = model == "archard" ? WearModelKind::kArchard : WearModelKind::kFrictionalPower;
  config::read_fields(node, WearParams::fields(), &wear);
  return wear;
}

Eigen::Vector2d get_point(const ConfigNode& node, const std::string& key) {
  const std::vector<double> xy = node.get_doubles(key, 2);
  return {xy[0], xy[1]};
}

}  // namespace

VehicleParams load_vehicle_config(const ConfigNode& node) {
  VehicleParams params(load_module_layout(node));
  params.name = node.get_string("name");
  (void)node.get_string_or("description", "");
  (void)node.child("mass");  // required, as is yaw_inertia
  (void)node.child("yaw_inertia");
  config::read_fields(node, VehicleParams::fields(), &params);
  if (node.has("center_of_mass")) params.center_of_mass_body = get_point(node, "center_of_mass");
  if (const auto casters = node.optional_child("casters")) {
    for (std::size_t j = 0; j < casters->size(); ++j) {
      const ConfigNode caster = casters->at(j);
      CasterParams c;
      c.position_body = get_point(caster, "position");
      config::read_fields(caster, CasterParams::fields(), &c);
      params.casters.push_back(c);
    }
  }
  if (const auto actuators = node.optional_child("actuators")) {
    config::read_fields(*actuators, ActuatorParams::fields(), &params.actuators);
  }
  params.tire = load_tire(node.child("tire"));
  if (const auto wear = node.optional_child("wear")) params.wear = load_wear(*wear);
  if (const auto plant = node.optional_child("plant")) {
    config::read_fields(*plant, PlantOptions::fields(), &params.plant);
    if (params.plant.load_transfer && !params.cog_height) {
      plant->fail_at("load_transfer", "= true: needs vehicle.cog_height");
    }
  }
  try {
    params.validate();
  } catch (const ConfigError& error) {
    node.fail(error.what());  // keep the file and path in front of the physical rule
  }
  return params;
}

VehicleParams load_vehicle_config_file(const std::string& file_path) {
  const ConfigNode root = ConfigNode::load_file(file_path);
  VehicleParams params = load_vehicle_config(root.child("vehicle"));
  root.expect_all_read();
  return params;
}

}  // namespace swerve
