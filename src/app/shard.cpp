#include "swerve/app/shard.hpp"

#include <charconv>

#include "swerve/core/config_error.hpp"
#include "swerve/core/error_text.hpp"

namespace swerve {

void Shard::validate() const {
  if (count < 1) throw_invalid_field("Shard", "count", count, "must be >= 1");
  if (index < 0 || index >= count) {
    throw_invalid_field("Shard", "index", index, "must be in [0, " + std::to_string(count - 1) + "] (of " +
                                                     std::to_string(count) + " shards)");
  }
}

Shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  const auto integer = [](const std::string& part, int* value) {
    const char* end = part.data() + part.size();
    const auto [stop, error] = std::from_chars(part.data(), end, *value);
    return !part.empty() && error == std::errc() && stop == end;
  };
  Shard shard;
  if (slash == std::string::npos || !integer(text.substr(0, slash), &shard.index) ||
      !integer(text.substr(slash + 1), &shard.count)) {
    throw ConfigError("--shard '" + printable_value(text) + "': expected I/N, two integers with 0 <= I < N");
  }
  if (shard.count < 1) throw ConfigError("--shard '" + printable_value(text) + "': N must be >= 1");
  if (shard.index < 0 || shard.index >= shard.count) {
    throw ConfigError("--shard '" + printable_value(text) + "': I must be in [0, " + std::to_string(shard.count - 1) +
                      "]");
  }
  return shard;
}

}  // namespace swerve
