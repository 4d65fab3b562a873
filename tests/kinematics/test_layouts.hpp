// Layouts shared by the kinematics tests: one per module count 2..8, each family non-square, and
// seeded random layouts for property tests.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "swerve/kinematics/module_layout.hpp"

#include "support/named_layout.hpp"

namespace swerve::testing {

// Every module count 2..8, covering each builder with non-square proportions.
inline std::vector<NamedLayout> layouts_2_to_8() {
  return {
      {"two_module_plus_caster", ModuleLayout::two_module(0.3, 0.5, 0.05)},
      {"triangle", ModuleLayout::triangle(0.4, 0.05)},
      {"rectangle_0.6x0.4", ModuleLayout::rectangle(0.6, 0.4, 0.05)},
      {"irregular_pentagon", ModuleLayout({{0.5, 0.1}, {0.1, 0.45}, {-0.4, 0.3}, {-0.35, -0.3}, {0.2, -0.4}}, 0.05)},
      {"multi_axle_3", ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05)},
      {"irregular_heptagon",
       ModuleLayout({{0.7, 0.0}, {0.4, 0.5}, {-0.1, 0.6}, {-0.6, 0.3}, {-0.6, -0.3}, {-0.1, -0.6}, {0.45, -0.45}},
                    0.05)},
      {"multi_axle_4", ModuleLayout::multi_axle(4, 0.4, 0.7, 0.05)},
  };
}

// Random positions in a 2 m square, not centred on the reference point.
inline ModuleLayout random_layout(int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> coordinate(-1.0, 1.0);
  std::vector<Eigen::Vector2d> positions;
  while (static_cast<int>(positions.size()) < count) {
    const Eigen::Vector2d p(coordinate(rng) + 0.2, coordinate(rng) - 0.1);
    bool separate = true;
    for (const auto& q : positions) separate = separate && (p - q).norm() > 0.1;
    if (separate) positions.push_back(p);
  }
  return ModuleLayout(positions, 0.05);
}

inline Eigen::Vector3d random_twist(std::mt19937& rng) {
  std::uniform_real_distribution<double> value(-2.0, 2.0);
  return {value(rng), value(rng), value(rng)};
}

}  // namespace swerve::testing
