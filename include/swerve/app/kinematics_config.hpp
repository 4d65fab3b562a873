// The YAML loaders of the kinematics layer's plain structs: a vehicle's module layout and the
// kinematics options. Kinematics itself never sees YAML; these read the keys and leave every rule
// to the structs' own validation (ModuleLayout's constructor, KinematicsOptions::validate).
#pragma once

#include "swerve/app/config_node.hpp"
#include "swerve/kinematics/kinematics.hpp"
#include "swerve/kinematics/module_layout.hpp"

namespace swerve {

// Reads the module geometry of a `vehicle:` section: `wheel_radius`, `modules` (a list of
// {position: [x, y]}) and the optional `limits` map (keys as in ModuleLimits, without `max_`/`min_`
// prefixes: drive_speed, drive_acceleration, steering_rate, steering_angle: [min, max]).
ModuleLayout load_module_layout(const config::ConfigNode& vehicle_node);

// Reads an optional `kinematics:` map (keys as the field names; every key optional with the
// defaults above).
KinematicsOptions load_kinematics_options(const config::ConfigNode& kinematics_node);

}  // namespace swerve
