// Physical parameters of a swerve vehicle: rigid body, module geometry (a ModuleLayout, the one
// source of positions and limits), passive casters, actuators, tires, wear, and the extra physics
// the simulated plant may switch on. Plain data filled by the config layer; validate() checks it.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

#include "swerve/core/option_fields.hpp"
#include "swerve/kinematics/module_layout.hpp"
#include "swerve/models/magic_formula_tire.hpp"
#include "swerve/models/tire_wear.hpp"

namespace swerve {

// A passive, self-aligning caster wheel: carries part of the weight and, assumed always aligned with
// its contact velocity (no lateral force once aligned), only resists rolling:
// F_body = -c_rr Fz v_c / sqrt(|v_c|^2 + eps^2).
struct CasterParams {
  Eigen::Vector2d position_body = Eigen::Vector2d::Zero();  // m, contact point
  double rolling_resistance = 0.02;                           // c_rr, dimensionless
  static const OptionFields<CasterParams>& fields();  // the rules, read by the YAML loader too
};

// First-order lag of the low-level drive loops (plant fidelity only).
struct ActuatorParams {
  double steering_time_constant = 0.05;  // s, steering-rate loop (docs/paper.md, assumption 7)
  double drive_time_constant = 0.05;     // s, wheel-speed loop
  static const OptionFields<ActuatorParams>& fields();  // the rules, read by the YAML loader too
};

// Physics the simulated plant adds on top of the MPC's model (used with Fidelity::kPlant only).
struct PlantOptions {
  bool actuator_lag = true;         // wheel speed and steering rate follow commands with a 1st-order lag
  bool actuator_saturation = true;  // clamp commands to ModuleLimits (speed, acceleration, rate, end stops)
  double relaxation_length = 0.0;   // m; > 0 adds transient slip states (Pacejka 2012, sec. 7.2.2)
  bool load_transfer = false;       // quasi-static load transfer from cog_height (needs cog_height)
  static const OptionFields<PlantOptions>& fields();  // the rules, read by the YAML loader too
};

struct VehicleParams {
  explicit VehicleParams(ModuleLayout layout_in) : layout(std::move(layout_in)) {}

  std::string name;
  double mass = 800.0;         // kg
  double yaw_inertia = 2900.0; // kg m^2, about the vertical axis through the centre of mass
  // Centre of mass in the body frame (m). The state's pose and velocity are those of the body
  // origin (the point module positions are measured from), not of the CoM.
  Eigen::Vector2d center_of_mass_body = Eigen::Vector2d::Zero();
  std::optional<double> cog_height;  // m above the ground; needed only for load transfer
  double gravity = 9.81;             // m/s^2
  ModuleLayout layout;               // module positions, wheel radius, limits
  std::vector<CasterParams> casters;
  ActuatorParams actuators;
  MagicFormulaParams tire;
  WearParams wear;
  PlantOptions plant;

  // The rules of mass, yaw_inertia and gravity (the nested structs have tables of their own).
  static const OptionFields<VehicleParams>& fields();
  // Throws ConfigError naming the field and value ("VehicleParams.mass = -1: must be finite and
  // > 0"), also when the static loads cannot be found (centre of mass off the support line, or a
  // contact would have to pull: a negative load).
  void validate() const;

  // Static normal loads (N), modules first (layout order) then casters: the least-norm solution of
  // static equilibrium (sum Fz = m g, zero moment about the CoM), i.e. Fz = A^T (A A^T)^+ b with
  // rows A = [1; x_i - x_c; y_i - y_c], b = [m g; 0; 0]. Exact for statically determinate layouts
  // (3 contacts, or 2 with the CoM on their line) and m g / n for symmetric ones (docs/paper.md,
  // assumption 2). Throws ConfigError as validate() does.
  std::vector<double> static_normal_loads() const;
  // Each module's share of the modules' static load (n entries summing to 1; casters left out).
  // Throws as static_normal_loads().
  std::vector<double> static_load_shares() const;
};

}  // namespace swerve
