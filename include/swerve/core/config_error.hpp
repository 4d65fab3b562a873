// The one exception type of SwerveMPC's configuration and construction tier: thrown when a config
// file, a parameter struct or a constructor argument is invalid. The message always names where
// (file and key path, or the struct field), the offending value and the rule it broke.
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>

#include "swerve/core/error_text.hpp"

namespace swerve {

// Longest ConfigError message kept: room for a nested "cannot load: <inner error>" chain, but a
// message that echoes a huge value unabbreviated is still cut.
inline constexpr std::size_t kMaxConfigErrorChars = 1000;

class ConfigError : public std::runtime_error {
 public:
  // The message is kept to one line (control characters escaped) and kMaxConfigErrorChars, the
  // promise the CLI's "one line on stderr" rests on; each throw site abbreviates its values itself.
  explicit ConfigError(const std::string& message)
      : std::runtime_error(printable_value(message, kMaxConfigErrorChars)) {}
};

// Throws ConfigError "<owner>.<field> = <value>: <rule>" (without "<owner>." when owner is empty),
// the one message format of every parameter struct's validate(). The value is shown through
// printable_value, so a long or multi-line value still gives a short, one-line message.
template <typename Value>
[[noreturn]] void throw_invalid_field(const std::string& owner, const std::string& field, const Value& value,
                                      const std::string& rule) {
  std::ostringstream shown;
  shown << value;
  std::ostringstream message;
  if (!owner.empty()) message << owner << '.';
  message << field << " = " << printable_value(shown.str()) << ": " << rule;
  throw ConfigError(message.str());
}

}  // namespace swerve
