// Reads an options struct's fields from YAML by its table (core/option_fields.hpp): each key the
// table names, where present, is read with its type and checked against the table's bound or
// choices right there, so the error names the file, the key path and the value. The loaders list
// no rule of their own.
#pragma once

#include <algorithm>
#include <climits>
#include <cmath>
#include <string>
#include <vector>

#include "swerve/app/config_node.hpp"
#include "swerve/core/option_fields.hpp"

namespace swerve::config {

namespace detail {

// An int field's bound as the closed int interval get_int takes.
inline int int_lower(const Bound& bound) {
  if (!bound.has_lower()) return INT_MIN + 1;
  const double lo = bound.lower_open ? std::floor(bound.lower) + 1.0 : std::ceil(bound.lower);
  return static_cast<int>(std::clamp(lo, static_cast<double>(INT_MIN + 1), static_cast<double>(INT_MAX)));
}
inline int int_upper(const Bound& bound) {
  if (!bound.has_upper()) return INT_MAX;
  const double hi = bound.upper_open ? std::ceil(bound.upper) - 1.0 : std::floor(bound.upper);
  return static_cast<int>(std::clamp(hi, static_cast<double>(INT_MIN + 1), static_cast<double>(INT_MAX)));
}

}  // namespace detail

// Every field of `fields` whose key `node` holds is read into *options; the others keep their
// value. Throws ConfigError "<file>: <path>.<key> = <value>: <rule>" for a value of the wrong type
// or outside its rule, and "<file>: <path>: expected a map" when `node` is not a map.
template <typename Options>
void read_fields(const ConfigNode& node, const OptionFields<Options>& fields, Options* options) {
  (void)node.keys();  // "expected a map, got ..." for a block that is not one (`weights: 5`)
  for (const OptionField<Options>& field : fields) {
    const std::string key = field.yaml_key();
    if (!node.has(key)) continue;
    if (const auto* real = std::get_if<double Options::*>(&field.member)) {
      options->*(*real) = node.get_double(key, field.bound);
    } else if (const auto* maybe = std::get_if<std::optional<double> Options::*>(&field.member)) {
      options->*(*maybe) = node.get_double(key, field.bound);
    } else if (const auto* whole = std::get_if<int Options::*>(&field.member)) {
      options->*(*whole) = node.get_int(key, detail::int_lower(field.bound), detail::int_upper(field.bound));
    } else if (const auto* flag = std::get_if<bool Options::*>(&field.member)) {
      options->*(*flag) = node.get_bool(key);
    } else if (const auto* vector = std::get_if<Eigen::Vector3d Options::*>(&field.member)) {
      const std::vector<double> v = node.get_doubles(key, 3, field.bound);
      options->*(*vector) = Eigen::Vector3d(v[0], v[1], v[2]);
    } else if (const auto* text = std::get_if<std::string Options::*>(&field.member)) {
      options->*(*text) = field.choices.empty() ? node.get_string(key) : node.child(key).as_choice(field.choices);
    }
  }
}

}  // namespace swerve::config
