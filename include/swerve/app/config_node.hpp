// A checked view of one YAML node: every read names the file and the full key path in its error
// (`configs/vehicles/x.yaml: vehicle.modules[2].position: expected a list of 2 numbers, got 3`),
// numbers must be finite, and keys that no loader read are reported as errors, so typos never pass.
#pragma once

#include <array>
#include <cstddef>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "swerve/core/config_error.hpp"
#include "swerve/core/option_fields.hpp"
#include "swerve/core/text_file.hpp"

namespace YAML {
class Node;
}

namespace swerve::config {

// A document may hold at most this many values (map keys, map values and list elements) once YAML
// aliases are expanded: 1 MiB of text holds fewer, so only an alias bomb ("billion laughs") hits it.
inline constexpr std::size_t kMaxConfigValues = 1000000;

// Lists and maps may nest this deep (the shipped configs reach 4), and an alias may not name a list
// or map that contains it (`c: &c [*c]`): a cycle or a 4000-deep `[[[[...` overflowed the stack.
inline constexpr std::size_t kMaxConfigDepth = 64;


// The allowed interval of a number (core/option_fields.hpp), as the loaders name it.
using swerve::Bound;

class ConfigNode {
 public:
  // Parses a file. Throws ConfigError naming the file when it is missing, not a regular file,
  // larger than kMaxConfigFileBytes, or fails parse().
  static ConfigNode load_file(const std::string& file_path);
  // Parses text; `source_name` stands in for the file name in messages. Throws ConfigError for a
  // YAML syntax error (file:line:column), a second document after `---`, a top level that is not a
  // map, a key that is not a plain scalar, text that is not UTF-8 (naming the key path), and more
  // than kMaxConfigValues values.
  static ConfigNode parse(const std::string& yaml_text, const std::string& source_name = "<string>");

  ConfigNode(const ConfigNode&);
  ConfigNode& operator=(const ConfigNode&);
  ~ConfigNode();

  const std::string& source() const;  // the file name, as given
  const std::string& path() const;    // key path from the document root, "" at the root

  bool is_map() const;
  bool is_sequence() const;
  bool is_scalar() const;
  bool has(const std::string& key) const;  // also marks nothing as read
  std::size_t size() const;                // number of elements of a sequence (errors otherwise)

  // Children. A required child that is missing is an error naming the key.
  ConfigNode child(const std::string& key) const;
  std::optional<ConfigNode> optional_child(const std::string& key) const;
  ConfigNode at(std::size_t index) const;  // sequence element
  std::vector<std::string> keys() const;   // map keys in file order (marks nothing as read)

  // Typed scalars of this node.
  double as_double(const Bound& bound = Bound::any()) const;
  int as_int(int lower = -2147483647, int upper = 2147483647) const;
  bool as_bool() const;
  std::string as_string() const;
  std::vector<double> as_doubles(std::size_t expected_size = 0, const Bound& bound = Bound::any()) const;
  // A string that must be one of `allowed`; the message lists them.
  std::string as_choice(std::initializer_list<const char*> allowed) const;
  std::string as_choice(const std::vector<std::string>& allowed) const;

  // Typed members of this map; the `_or` forms document their default by taking it.
  double get_double(const std::string& key, const Bound& bound = Bound::any()) const;
  double get_double_or(const std::string& key, double fallback, const Bound& bound = Bound::any()) const;
  int get_int(const std::string& key, int lower = -2147483647, int upper = 2147483647) const;
  int get_int_or(const std::string& key, int fallback, int lower = -2147483647,
                 int upper = 2147483647) const;
  bool get_bool(const std::string& key) const;
  bool get_bool_or(const std::string& key, bool fallback) const;
  std::string get_string(const std::string& key) const;
  std::string get_string_or(const std::string& key, const std::string& fallback) const;
  std::vector<double> get_doubles(const std::string& key, std::size_t expected_size = 0,
                                  const Bound& bound = Bound::any()) const;
  std::string get_choice(const std::string& key, std::initializer_list<const char*> allowed) const;
  std::string get_choice_or(const std::string& key, std::initializer_list<const char*> allowed,
                            const std::string& fallback) const;

  // Throws ConfigError "<file>: <path>: <what>" (path of this node, or of `key` below it); a
  // `what` that already starts with "<path>: " keeps its path once.
  [[noreturn]] void fail(const std::string& what) const;
  [[noreturn]] void fail_at(const std::string& key, const std::string& what) const;

  // After all loaders have read the document: throws for the first map key (in file order) that no
  // loader read, suggesting the closest key that was read beside it ("did you mean 'mass'?").
  // Duplicate keys in one map are reported here too.
  void expect_all_read() const;

  // The value of this node rendered back as flow-style YAML for error messages: one line, cut to
  // kMaxEchoedValueChars characters.
  std::string to_yaml() const;

 private:
  struct Document;
  ConfigNode(std::shared_ptr<Document> document, const YAML::Node& node, std::string path);
  void mark_read() const;
  std::string child_path(const std::string& key) const;

  std::shared_ptr<Document> document_;
  std::unique_ptr<YAML::Node> node_;
  std::string path_;
};

// Joins a key path and a member name ("vehicle" + "mass" -> "vehicle.mass"; "" + "x" -> "x").
std::string join_path(const std::string& parent, const std::string& key);

}  // namespace swerve::config
