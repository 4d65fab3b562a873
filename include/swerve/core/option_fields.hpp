// An options struct's rules, written once: a table of its fields, each with its name, where it sits
// in the struct and the values it allows. The struct's validate() checks the table (check_fields),
// and the YAML loaders read the same table's keys and check each value where they read it, naming
// the file and key (app/option_reader.hpp). So no range is written twice, and a loader cannot
// disagree with validate(): they did, when each wrote its own (flip_hysteresis).
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "swerve/core/config_error.hpp"

namespace swerve {

// An allowed interval of a number. A NaN or an infinity is in none (an unbounded end is +-1e308).
struct Bound {
  double lower = -1e308;
  double upper = 1e308;
  bool lower_open = false;
  bool upper_open = false;

  static Bound any() { return {}; }
  static Bound positive() { return {0.0, 1e308, true, false}; }
  static Bound non_negative() { return {0.0, 1e308, false, false}; }
  static Bound at_least(double lo) { return {lo, 1e308, false, false}; }
  static Bound closed(double lo, double hi) { return {lo, hi, false, false}; }
  static Bound open(double lo, double hi) { return {lo, hi, true, true}; }          // (lo, hi)
  static Bound half_open(double lo, double hi) { return {lo, hi, true, false}; }   // (lo, hi]
  static Bound right_open(double lo, double hi) { return {lo, hi, false, true}; }  // [lo, hi)

  bool has_lower() const { return lower > -1e307; }
  bool has_upper() const { return upper < 1e307; }
  bool contains(double value) const {
    const bool above = lower_open ? value > lower : value >= lower;
    const bool below = upper_open ? value < upper : value <= upper;
    return above && below;
  }
  // In words: "must be > 0", "must be in (0, 1]"; "must be a finite number" for any().
  std::string describe() const {
    if (has_lower() && has_upper()) {
      return std::string("must be in ") + (lower_open ? "(" : "[") + number(lower) + ", " + number(upper) +
             (upper_open ? ")" : "]");
    }
    if (has_lower()) return std::string("must be ") + (lower_open ? "> " : ">= ") + number(lower);
    if (has_upper()) return std::string("must be ") + (upper_open ? "< " : "<= ") + number(upper);
    return "must be a finite number";
  }
  // describe() for a value that may be infinite (a struct set in code, not read from text):
  // "must be finite and > 0" where only one side is bounded.
  std::string describe_finite() const {
    if (has_lower() == has_upper()) return describe();
    return "must be finite and " + describe().substr(std::string("must be ").size());
  }
  static std::string number(double value) {
    std::ostringstream out;
    out.precision(10);
    out << value;
    return out.str();
  }
};

// One field of Options: what validate() names it, where it is, and what it allows.
template <typename Options>
struct OptionField {
  // std::optional<double>: a number that may be left unset (checked only when set).
  using Member = std::variant<double Options::*, int Options::*, bool Options::*, Eigen::Vector3d Options::*,
                              std::string Options::*, std::optional<double> Options::*>;
  const char* name;                   // the member's name, as validate()'s messages say it
  Member member;
  Bound bound = Bound::any();         // numbers (every entry of a vector, finite); unused otherwise
  std::vector<std::string> choices{};  // strings: the values allowed (empty: any)
  const char* key = nullptr;          // the YAML key, where it is not `name`
  const char* note = nullptr;         // said after the rule in validate()'s message, e.g. "(m)"

  const char* yaml_key() const { return key != nullptr ? key : name; }
};

template <typename Options>
using OptionFields = std::vector<OptionField<Options>>;

namespace detail {

inline std::string with_note(std::string rule, const char* note) {
  return note != nullptr ? rule + " " + note : rule;
}

inline std::string choice_list(const std::vector<std::string>& choices) {
  std::string listing;
  for (std::size_t i = 0; i < choices.size(); ++i) {
    listing += i == 0 ? "" : (i + 1 == choices.size() ? " or " : ", ");
    listing += choices[i];
  }
  return listing;
}

}  // namespace detail

// Throws ConfigError "<owner>.<name> = <value>: <rule>" (throw_invalid_field) for the first field
// of `fields`, in order, whose value `options` holds outside its bound or choices.
template <typename Options>
void check_fields(const char* owner, const Options& options, const OptionFields<Options>& fields) {
  for (const OptionField<Options>& field : fields) {
    if (const auto* real = std::get_if<double Options::*>(&field.member)) {
      const double value = options.*(*real);
      if (!std::isfinite(value) || !field.bound.contains(value)) {
        throw_invalid_field(owner, field.name, value, detail::with_note(field.bound.describe_finite(), field.note));
      }
    } else if (const auto* maybe = std::get_if<std::optional<double> Options::*>(&field.member)) {
      const std::optional<double>& value = options.*(*maybe);
      if (value && (!std::isfinite(*value) || !field.bound.contains(*value))) {
        throw_invalid_field(owner, field.name, *value, detail::with_note(field.bound.describe_finite(), field.note));
      }
    } else if (const auto* whole = std::get_if<int Options::*>(&field.member)) {
      const int value = options.*(*whole);
      if (!field.bound.contains(value)) {
        throw_invalid_field(owner, field.name, value, detail::with_note(field.bound.describe(), field.note));
      }
    } else if (const auto* vector = std::get_if<Eigen::Vector3d Options::*>(&field.member)) {
      const Eigen::Vector3d& value = options.*(*vector);
      for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(value[i]) || !field.bound.contains(value[i])) {
          const std::string shown = "[" + Bound::number(value[0]) + ", " + Bound::number(value[1]) + ", " +
                                    Bound::number(value[2]) + "]";
          throw_invalid_field(owner, field.name, shown,
                              detail::with_note(field.bound.describe_finite() + " on every axis", field.note));
        }
      }
    } else if (const auto* text = std::get_if<std::string Options::*>(&field.member)) {
      const std::string& value = options.*(*text);
      bool allowed = field.choices.empty();
      for (const std::string& choice : field.choices) allowed = allowed || value == choice;
      if (!allowed) {
        throw_invalid_field(owner, field.name, value,
                            detail::with_note("must be " + detail::choice_list(field.choices), field.note));
      }
    }
  }
}

}  // namespace swerve
