// Loads a `vehicle:` section (configs/vehicles/*.yaml) into VehicleParams: body, module geometry
// (through load_module_layout), casters, actuators, Magic Formula tire, wear model and the plant's
// extra physics. Unknown keys are left for ConfigNode::expect_all_read to reject.
#pragma once

#include <string>

#include "swerve/app/config_node.hpp"
#include "swerve/models/vehicle_params.hpp"

namespace swerve {

// Keys (defaults in brackets; SI units):
//   name, description [""], mass, yaw_inertia, center_of_mass [[0, 0]], cog_height [absent],
//   gravity [9.81], wheel_radius, modules, limits  (see load_module_layout)
//   casters [none]: [{position: [x, y], rolling_resistance [0.02]}]
//   actuators [all defaults]: {steering_time_constant [0.05], drive_time_constant [0.05]}
//   tire: {mu, longitudinal: {B, C, E [0], mu [tire.mu]}, lateral: {B, C, E [0], mu [tire.mu]},
//          (mu may be left out when both channels give their own)
//          combined_slip [normalized_slip] (none | ellipse_cap | normalized_slip),
//          slip_speed_epsilon [0.05], smooth_slip [true]}
//   wear [frictional_power, k = 1]: {model (frictional_power | archard), coefficient [1], smoothing [0]}
//   plant [defaults of PlantOptions]: {actuator_lag [true], actuator_saturation [true],
//          relaxation_length [0], load_transfer [false]}
// Errors name the file, the key path and the value; VehicleParams::validate() runs last.
VehicleParams load_vehicle_config(const config::ConfigNode& vehicle_node);

// Loads a whole file with a top-level `vehicle:` section and rejects unknown keys.
VehicleParams load_vehicle_config_file(const std::string& file_path);

}  // namespace swerve
