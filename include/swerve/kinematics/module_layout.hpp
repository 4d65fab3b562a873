// Where the swerve modules sit on the body and what they can do: the one description of module
// geometry that kinematics, the dynamic model and the controller all share. Any count >= 2 of
// steered-and-driven modules; passive casters are not modules (the dynamic model carries them).
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "swerve/core/constants.hpp"
#include "swerve/core/option_fields.hpp"
#include "swerve/core/config_error.hpp"  // thrown by every validation in this layer

namespace swerve {

inline constexpr double kMinModuleSeparation = 1e-3;  // m; closer than this two modules are one point

struct ModuleLimits {
  double max_drive_speed = 2.0;           // m/s at the contact patch (wheel speed x radius)
  double max_drive_acceleration = 2.0;    // m/s^2
  double max_steering_rate = 1.0;         // rad/s
  double min_steering_angle = -kPi;       // rad; [-pi, pi] means the module turns without end stops
  double max_steering_angle = kPi;        // rad

  bool has_steering_end_stops() const { return min_steering_angle > -kPi || max_steering_angle < kPi; }
  // The rules of the drive and steering-rate limits (the steering range is one rule, in validate()).
  static const OptionFields<ModuleLimits>& fields();
  // Throws ConfigError naming the field and value ("ModuleLimits.max_drive_speed = -1: must be > 0").
  void validate() const;
};

class ModuleLayout {
 public:
  // Validates: 2 to kMaxModules (16) modules, finite positions, no two modules closer than 1 mm, the modules not
  // all on one point (forward kinematics needs rank 3), wheel radius > 0, limits valid.
  ModuleLayout(std::vector<Eigen::Vector2d> positions_body, double wheel_radius,
               ModuleLimits limits = ModuleLimits{});

  // Builders for the common shapes; the reference point (body origin) is the geometric centre.
  // 4 modules at (+-wheelbase/2, +-track/2), ordered front-left, front-right, rear-left, rear-right.
  static ModuleLayout rectangle(double wheelbase, double track, double wheel_radius,
                                ModuleLimits limits = ModuleLimits{});
  // 3 modules on a circle of `radius`, the first straight ahead, then counter-clockwise.
  static ModuleLayout triangle(double radius, double wheel_radius, ModuleLimits limits = ModuleLimits{});
  // 2 x axles modules; axle x positions spaced `axle_spacing` apart, centred on the origin, front
  // axle first, each axle left then right (y = +-track/2).
  static ModuleLayout multi_axle(int axles, double axle_spacing, double track, double wheel_radius,
                                 ModuleLimits limits = ModuleLimits{});
  // 2 steered modules side by side at (module_x, +-track/2); the passive caster that carries the
  // rest of the body is not a module (see VehicleParams::casters).
  static ModuleLayout two_module(double module_x, double track, double wheel_radius,
                                 ModuleLimits limits = ModuleLimits{});

  // The same modules measured from another reference point (body coordinates in this layout),
  // e.g. the centre of mass: kinematics built on the result reports that point's twist.
  ModuleLayout recentered(const Eigen::Vector2d& reference_point_body) const;

  int size() const { return static_cast<int>(positions_body_.size()); }
  const Eigen::Vector2d& position_body(int module) const {
    return positions_body_[static_cast<std::size_t>(module)];
  }
  const std::vector<Eigen::Vector2d>& positions_body() const { return positions_body_; }
  double wheel_radius() const { return wheel_radius_; }
  const ModuleLimits& limits() const { return limits_; }

 private:
  std::vector<Eigen::Vector2d> positions_body_;
  double wheel_radius_;
  ModuleLimits limits_;
};

}  // namespace swerve
