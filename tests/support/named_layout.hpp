// A module layout with the name a parameterised test reports it by.
#pragma once

#include <string>

#include "swerve/kinematics/module_layout.hpp"

namespace swerve::testing {

struct NamedLayout {
  std::string name;
  ModuleLayout layout;
};

}  // namespace swerve::testing
