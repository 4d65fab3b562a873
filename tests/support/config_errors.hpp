// The message of the ConfigError a piece of code throws, for tests of input checking: they compare
// the message, which must name the field and the value.
#pragma once

#include <string>

#include "swerve/core/config_error.hpp"

namespace swerve::testing {

// Runs `body` and returns the ConfigError message it throws ("" when it throws nothing).
template <typename Body>
std::string config_error_of(Body body) {
  try {
    body();
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "";
}

}  // namespace swerve::testing
