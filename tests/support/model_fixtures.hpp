// Shared test fixtures for the models: vehicles with 2, 3, 4, 6, 8 and 16 modules built from
// ModuleLayout's shape builders, with mass and inertia scaled to the footprint.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "swerve/models/vehicle_params.hpp"

#include "support/named_layout.hpp"

namespace swerve::testing {

inline std::vector<NamedLayout> test_layouts() {
  return {
      {"two_modules", ModuleLayout({{0.0, 0.3}, {0.0, -0.3}}, 0.1)},
      {"triangle_3", ModuleLayout::triangle(0.35, 0.075)},
      {"rectangle_4", ModuleLayout::rectangle(0.8, 0.6, 0.1)},
      {"axles_6", ModuleLayout::multi_axle(3, 0.8, 0.7, 0.1)},
      {"axles_8", ModuleLayout::multi_axle(4, 1.2, 1.4, 0.2)},
      {"axles_16", ModuleLayout::multi_axle(8, 0.6, 0.9, 0.15)},
  };
}

// Default tire/wear (docs/paper.md, assumptions 4, 5); 40 kg per module; plate inertia.
inline VehicleParams make_params(const ModuleLayout& layout) {
  VehicleParams params(layout);
  params.name = "test";
  params.mass = 40.0 * layout.size();
  double max_x = 0.0;
  double max_y = 0.0;
  for (const auto& p : layout.positions_body()) {
    max_x = std::max(max_x, std::abs(p.x()));
    max_y = std::max(max_y, std::abs(p.y()));
  }
  const double length = 2.0 * max_x + 0.4;
  const double width = 2.0 * max_y + 0.4;
  params.yaw_inertia = params.mass * (length * length + width * width) / 12.0;
  return params;
}

inline VehicleParams make_params(int modules) {
  for (const auto& named : test_layouts()) {
    if (named.layout.size() == modules) return make_params(named.layout);
  }
  return make_params(ModuleLayout::multi_axle(modules / 2, 0.6, 0.9, 0.15));
}

// A two-module robot with a rear caster (statically determinate, CoM ahead of the centre).
inline VehicleParams make_caster_params() {
  VehicleParams params(ModuleLayout::two_module(0.3, 0.5, 0.08));
  params.mass = 50.0;
  params.yaw_inertia = 4.9;
  params.center_of_mass_body = {0.05, 0.0};
  params.cog_height = 0.25;
  CasterParams caster;
  caster.position_body = {-0.35, 0.0};
  caster.rolling_resistance = 0.03;
  params.casters.push_back(caster);
  return params;
}

}  // namespace swerve::testing
