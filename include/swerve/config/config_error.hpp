// The one exception type of SwerveMPC's configuration and construction tier: thrown when a config
// file, a parameter struct or a constructor argument is invalid. The message always names where
// (file and key path, or the struct field), the offending value and the rule it broke.
#pragma once

#include <stdexcept>
#include <string>

namespace swerve {

class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace swerve
