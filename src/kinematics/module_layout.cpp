#include "swerve/kinematics/module_layout.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <sstream>

#include "swerve/kinematics/module_state.hpp"
#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

// Rules named by the field alone (throw_invalid_field with no owner).
constexpr const char* kOwner = "";

void require_positive(const std::string& field, double value) {
  if (!std::isfinite(value) || value <= 0.0) throw_invalid_field(kOwner, field, value, "must be finite and > 0");
}

}  // namespace

const OptionFields<ModuleLimits>& ModuleLimits::fields() {
  static const OptionFields<ModuleLimits> table{
      {"max_drive_speed", &ModuleLimits::max_drive_speed, Bound::positive(), {}, "drive_speed"},
      {"max_drive_acceleration", &ModuleLimits::max_drive_acceleration, Bound::positive(), {}, "drive_acceleration"},
      {"max_steering_rate", &ModuleLimits::max_steering_rate, Bound::positive(), {}, "steering_rate"},
  };
  return table;
}

void ModuleLimits::validate() const {
  check_fields("ModuleLimits", *this, fields());
  if (!std::isfinite(min_steering_angle) || min_steering_angle < -kPi - 1e-12) {
    throw_invalid_field(kOwner, "ModuleLimits.min_steering_angle", min_steering_angle, "must be in [-pi, pi]");
  }
  if (!std::isfinite(max_steering_angle) || max_steering_angle > kPi + 1e-12) {
    throw_invalid_field(kOwner, "ModuleLimits.max_steering_angle", max_steering_angle, "must be in [-pi, pi]");
  }
  if (min_steering_angle >= max_steering_angle) {
    throw_invalid_field(kOwner, "ModuleLimits.min_steering_angle", min_steering_angle, "must be < max_steering_angle");
  }
}

ModuleLayout::ModuleLayout(std::vector<Eigen::Vector2d> positions_body, double wheel_radius,
                           ModuleLimits limits)
    : positions_body_(std::move(positions_body)), wheel_radius_(wheel_radius), limits_(limits) {
  const std::size_t count = positions_body_.size();
  if (count < 2) throw_invalid_field(kOwner, "ModuleLayout.modules", count, "need at least 2 modules");
  // Every fixed-capacity buffer of the kinematics and controllers is sized by kMaxModules.
  if (count > static_cast<std::size_t>(kMaxModules)) {
    throw_invalid_field(kOwner, "ModuleLayout.modules", count, "at most " + std::to_string(kMaxModules) + " modules are supported");
  }
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector2d& p = positions_body_[i];
    if (!p.allFinite()) {
      throw_invalid_field(kOwner, "ModuleLayout.modules[" + std::to_string(i) + "].position", p.transpose(), "must be finite");
    }
    for (std::size_t j = 0; j < i; ++j) {
      if ((p - positions_body_[j]).norm() < kMinModuleSeparation) {
        throw_invalid_field(kOwner, "ModuleLayout.modules[" + std::to_string(i) + "].position", p.transpose(),
               "coincides with modules[" + std::to_string(j) + "]");
      }
    }
  }
  // Forward kinematics stacks [1 0 -y_i; 0 1 x_i] per module; it has rank 3 exactly when the
  // modules are not all on one point, which the separation check already guarantees for >= 2
  // modules. The explicit rank check guards that reasoning against future changes.
  Eigen::MatrixXd stacked(2 * static_cast<Eigen::Index>(count), 3);
  for (std::size_t i = 0; i < count; ++i) {
    const auto row = 2 * static_cast<Eigen::Index>(i);
    stacked.row(row) << 1.0, 0.0, -positions_body_[i].y();
    stacked.row(row + 1) << 0.0, 1.0, positions_body_[i].x();
  }
  if (Eigen::FullPivLU<Eigen::MatrixXd>(stacked).rank() < 3) {
    throw_invalid_field(kOwner, "ModuleLayout.modules", count, "module positions give a forward-kinematics matrix of rank < 3");
  }
  require_positive("ModuleLayout.wheel_radius", wheel_radius_);
  limits_.validate();
}

ModuleLayout ModuleLayout::recentered(const Eigen::Vector2d& reference_point_body) const {
  if (!reference_point_body.allFinite()) {
    throw_invalid_field(kOwner, "ModuleLayout::recentered reference_point_body", reference_point_body.transpose(), "must be finite");
  }
  std::vector<Eigen::Vector2d> shifted = positions_body_;
  for (Eigen::Vector2d& p : shifted) p -= reference_point_body;
  return ModuleLayout(std::move(shifted), wheel_radius_, limits_);
}

ModuleLayout ModuleLayout::rectangle(double wheelbase, double track, double wheel_radius, ModuleLimits limits) {
  require_positive("ModuleLayout::rectangle wheelbase", wheelbase);
  require_positive("ModuleLayout::rectangle track", track);
  const double hx = wheelbase / 2.0;
  const double hy = track / 2.0;
  return ModuleLayout({{hx, hy}, {hx, -hy}, {-hx, hy}, {-hx, -hy}}, wheel_radius, limits);
}

ModuleLayout ModuleLayout::triangle(double radius, double wheel_radius, ModuleLimits limits) {
  require_positive("ModuleLayout::triangle radius", radius);
  std::vector<Eigen::Vector2d> positions;
  for (int i = 0; i < 3; ++i) {
    const double angle = 2.0 * kPi * i / 3.0;
    positions.emplace_back(radius * std::cos(angle), radius * std::sin(angle));
  }
  return ModuleLayout(std::move(positions), wheel_radius, limits);
}

ModuleLayout ModuleLayout::multi_axle(int axles, double axle_spacing, double track, double wheel_radius,
                                      ModuleLimits limits) {
  if (axles < 1) throw_invalid_field(kOwner, "ModuleLayout::multi_axle axles", axles, "must be >= 1");
  require_positive("ModuleLayout::multi_axle axle_spacing", axle_spacing);
  require_positive("ModuleLayout::multi_axle track", track);
  std::vector<Eigen::Vector2d> positions;
  const double front_x = 0.5 * axle_spacing * (axles - 1);
  for (int axle = 0; axle < axles; ++axle) {
    const double x = front_x - axle * axle_spacing;
    positions.emplace_back(x, track / 2.0);
    positions.emplace_back(x, -track / 2.0);
  }
  return ModuleLayout(std::move(positions), wheel_radius, limits);
}

ModuleLayout ModuleLayout::two_module(double module_x, double track, double wheel_radius, ModuleLimits limits) {
  require_positive("ModuleLayout::two_module track", track);
  return ModuleLayout({{module_x, track / 2.0}, {module_x, -track / 2.0}}, wheel_radius, limits);
}


}  // namespace swerve
