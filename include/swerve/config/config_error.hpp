// The one exception type of SwerveMPC's configuration and construction tier: thrown when a config
// file, a parameter struct or a constructor argument is invalid. The message always names where
// (file and key path, or the struct field), the offending value and the rule it broke.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

namespace swerve {

class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::string& message) : std::runtime_error(message) {}
};

// Throws ConfigError "<owner>.<field> = <value>: <rule>" (without "<owner>." when owner is empty),
// the one message format of every parameter struct's validate().
template <typename Value>
[[noreturn]] void throw_invalid_field(const std::string& owner, const std::string& field, const Value& value,
                                      const std::string& rule) {
  std::ostringstream message;
  if (!owner.empty()) message << owner << '.';
  message << field << " = " << value << ": " << rule;
  throw ConfigError(message.str());
}

}  // namespace swerve
