// Checked YAML access: every failure names the file, the key path, the value and the rule.
#include "swerve/app/config_node.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace swerve::config {

struct ConfigNode::Document {
  std::string source;
  YAML::Node root;
  std::set<std::string> read_paths;  // every path read, with all its ancestors
};

namespace {

std::string describe_node(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Undefined:
      return "nothing";
    case YAML::NodeType::Scalar:
      return "'" + printable_value(node.Scalar()) + "'";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(node.size());
    case YAML::NodeType::Map:
      return "a map";
  }
  return "an unknown node";
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      const std::size_t cost = (a[i - 1] == b[j - 1]) ? 0 : 1;
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + cost});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string syntax_error(const std::string& shown, const YAML::Mark& mark, const std::string& what) {
  const std::string where =
      mark.is_null() ? shown : shown + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
  return where + ": YAML syntax error: " + what;
}

// Parser events of a YAML stream, kept only as where each document starts and where its root is.
class DocumentStarts final : public YAML::EventHandler {
 public:
  int documents() const { return static_cast<int>(starts_.size()); }
  const YAML::Mark& start(int document) const { return starts_[static_cast<std::size_t>(document)]; }
  const YAML::Mark& root(int document) const { return roots_[static_cast<std::size_t>(document)]; }

  void OnDocumentStart(const YAML::Mark& mark) override {
    starts_.push_back(mark);
    roots_.push_back(YAML::Mark::null_mark());
    depth_ = 0;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override { node(mark); }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
    ++depth_;
  }
  void OnSequenceEnd() override { --depth_; }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
    ++depth_;
  }
  void OnMapEnd() override { --depth_; }

 private:
  void node(const YAML::Mark& mark) {
    if (depth_ == 0 && !roots_.empty()) roots_.back() = mark;
  }
  std::vector<YAML::Mark> starts_, roots_;
  int depth_ = 0;
};

// Walks the whole document once, before any loader reads it, so that every later read can trust
// its text: each key is a plain scalar, every key and scalar is UTF-8 (the JSON report and the
// terminal need it; finding out after a simulation loses the run), and the expanded document stays
// within kMaxConfigValues and kMaxConfigDepth, without cycles (so later walks, such as
// expect_all_read, stay bounded too).
class TextChecker {
 public:
  explicit TextChecker(const std::string& source) : source_(source) {}

  void check(const YAML::Node& node, const std::string& path) {
    if (++values_ > kMaxConfigValues) {
      throw ConfigError(printable_value(source_, std::string::npos) + ": more than " +
                        std::to_string(kMaxConfigValues) +
                        " values once anchors and aliases are expanded: config files are limited to that");
    }
    switch (node.Type()) {
      case YAML::NodeType::Scalar:
        check_utf8(node.Scalar(), path, "value");
        return;
      case YAML::NodeType::Sequence:
        enter(node, path);
        for (std::size_t i = 0; i < node.size(); ++i) check(node[i], path + "[" + std::to_string(i) + "]");
        ancestors_.pop_back();
        return;
      case YAML::NodeType::Map:
        enter(node, path);
        for (const auto& entry : node) {
          if (!entry.first.IsScalar()) fail(path, "= " + describe_node(entry.first) + ": a key must be a plain string");
          const std::string& key = entry.first.Scalar();
          const std::string key_path = join_path(path, key);
          check_utf8(key, key_path, "key");
          check(entry.second, key_path);
        }
        ancestors_.pop_back();
        return;
      default:
        return;
    }
  }

 private:
  // A list or map inside itself (`c: &c [*c]`) would make every later walk endless, and deep
  // nesting would overflow the stack of every recursive walk: both are refused here, first.
  void enter(const YAML::Node& node, const std::string& path) {
    for (const YAML::Node& ancestor : ancestors_) {
      if (ancestor.is(node)) fail(path, "an alias of a list or map that contains it: config values cannot nest in themselves");
    }
    if (ancestors_.size() >= kMaxConfigDepth) {
      fail(path, "nested deeper than " + std::to_string(kMaxConfigDepth) + " lists and maps: config files are limited to that");
    }
    ancestors_.push_back(node);
  }

  void check_utf8(const std::string& text, const std::string& path, const char* what) {
    const std::size_t bad = find_invalid_utf8(text);
    if (bad == std::string::npos) return;
    char byte[8];
    std::snprintf(byte, sizeof byte, "0x%02x", static_cast<unsigned>(static_cast<unsigned char>(text[bad])));
    fail(path, "= '" + printable_value(text) + "': the " + what + " is not valid UTF-8 (byte " + byte +
                   " at offset " + std::to_string(bad) + "); config text must be UTF-8");
  }

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    std::string message = printable_value(source_, std::string::npos);
    if (!path.empty()) message += ": " + printable_value(path, 2 * kMaxEchoedValueChars);
    throw ConfigError(message + (what.rfind("= ", 0) == 0 ? " " : ": ") + what);
  }

  const std::string& source_;
  std::size_t values_ = 0;
  std::vector<YAML::Node> ancestors_;  // the lists and maps from the root down to the node checked
};

}  // namespace

std::string join_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

ConfigNode::ConfigNode(std::shared_ptr<Document> document, const YAML::Node& node, std::string path)
    : document_(std::move(document)), node_(std::make_unique<YAML::Node>(node)), path_(std::move(path)) {}

ConfigNode::ConfigNode(const ConfigNode& other)
    : document_(other.document_), node_(std::make_unique<YAML::Node>(*other.node_)), path_(other.path_) {}

ConfigNode& ConfigNode::operator=(const ConfigNode& other) {
  if (this != &other) {
    document_ = other.document_;
    node_ = std::make_unique<YAML::Node>(*other.node_);
    path_ = other.path_;
  }
  return *this;
}

ConfigNode::~ConfigNode() = default;

ConfigNode ConfigNode::load_file(const std::string& file_path) {
  return parse(read_text_file(file_path, TextFileRules{}), file_path);
}

ConfigNode ConfigNode::parse(const std::string& yaml_text, const std::string& source_name) {
  auto document = std::make_shared<Document>();
  document->source = source_name;
  const std::string shown = printable_value(source_name, std::string::npos);
  // The documents are counted (at most two) before the first is built: yaml-cpp 0.7's LoadAll never
  // returns on some malformed text (a lone ',': jbeder/yaml-cpp#1040, fixed after 0.8.0), handing
  // back a null document at the same place again and again until memory runs out.
  DocumentStarts starts;
  try {
    std::istringstream stream(yaml_text);
    YAML::Parser parser(stream);
    while (starts.documents() < 2 && parser.HandleNextDocument(starts)) {
    }
  } catch (const YAML::Exception& e) {
    throw ConfigError(syntax_error(shown, e.mark, printable_value(e.msg, 2 * kMaxEchoedValueChars)));
  }
  if (starts.documents() == 2 && starts.start(1).pos == starts.start(0).pos) {
    const auto at = static_cast<std::size_t>(std::max(0, starts.start(1).pos));
    throw ConfigError(syntax_error(shown, starts.start(1),
                                   "unexpected '" + printable_value(yaml_text.substr(at, 1)) + "'"));
  }
  // Loaders read one document; a second one after `---` would otherwise be silently ignored.
  if (starts.documents() > 1) {
    const YAML::Mark mark = starts.root(1);
    throw ConfigError((mark.is_null() ? shown : shown + ":" + std::to_string(mark.line + 1)) +
                      ": a second YAML document (after '---'): a config file holds exactly one document");
  }
  if (starts.documents() == 0) {
    throw ConfigError(shown + ": the file is empty: expected a map of keys at the top level");
  }
  try {
    document->root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {  // not expected: the same text just parsed
    throw ConfigError(syntax_error(shown, e.mark, printable_value(e.msg, 2 * kMaxEchoedValueChars)));
  }
  if (!document->root.IsMap()) {
    throw ConfigError(shown + ": expected a map of keys at the top level, got " + describe_node(document->root));
  }
  TextChecker(source_name).check(document->root, "");
  return ConfigNode(document, document->root, "");
}

const std::string& ConfigNode::source() const { return document_->source; }
const std::string& ConfigNode::path() const { return path_; }
bool ConfigNode::is_map() const { return node_->IsMap(); }
bool ConfigNode::is_sequence() const { return node_->IsSequence(); }
bool ConfigNode::is_scalar() const { return node_->IsScalar(); }

bool ConfigNode::has(const std::string& key) const {
  return node_->IsMap() && static_cast<bool>((*node_)[key]);
}

std::size_t ConfigNode::size() const {
  if (!node_->IsSequence()) fail("expected a list, got " + describe_node(*node_));
  return node_->size();
}

std::string ConfigNode::child_path(const std::string& key) const { return join_path(path_, key); }

void ConfigNode::mark_read() const {
  // Record this path and every ancestor, so a parent counts as read when any child is.
  std::string path = path_;
  while (!path.empty()) {
    if (!document_->read_paths.insert(path).second) return;
    const std::size_t cut = path.find_last_of(".[");
    path = (cut == std::string::npos) ? std::string() : path.substr(0, cut);
  }
}

ConfigNode ConfigNode::child(const std::string& key) const {
  if (!node_->IsMap()) fail("expected a map containing '" + key + "', got " + describe_node(*node_));
  const YAML::Node value = (*node_)[key];
  if (!value) fail_at(key, "required key is missing");
  ConfigNode result(document_, value, child_path(key));
  result.mark_read();
  return result;
}

std::optional<ConfigNode> ConfigNode::optional_child(const std::string& key) const {
  if (!has(key)) {
    if (!node_->IsMap()) fail("expected a map, got " + describe_node(*node_));
    return std::nullopt;
  }
  return child(key);
}

ConfigNode ConfigNode::at(std::size_t index) const {
  const std::size_t count = size();
  if (index >= count) {
    fail("index " + std::to_string(index) + " is past the end of a list of " + std::to_string(count));
  }
  ConfigNode result(document_, (*node_)[index], path_ + "[" + std::to_string(index) + "]");
  result.mark_read();
  return result;
}

std::vector<std::string> ConfigNode::keys() const {
  if (!node_->IsMap()) fail("expected a map, got " + describe_node(*node_));
  std::vector<std::string> result;
  for (const auto& entry : *node_) result.push_back(entry.first.as<std::string>());
  return result;
}

double ConfigNode::as_double(const Bound& bound) const {
  mark_read();
  if (!node_->IsScalar()) fail("expected a number, got " + describe_node(*node_));
  double value = 0.0;
  try {
    value = node_->as<double>();
  } catch (const YAML::Exception&) {
    fail("expected a number, got " + describe_node(*node_));
  }
  if (!std::isfinite(value)) fail("= " + printable_value(node_->Scalar()) + ": must be a finite number");
  if (!bound.contains(value)) fail("= " + printable_value(node_->Scalar()) + ": " + bound.describe());
  return value;
}

int ConfigNode::as_int(int lower, int upper) const {
  mark_read();
  if (!node_->IsScalar()) fail("expected an integer, got " + describe_node(*node_));
  long long value = 0;
  try {
    value = node_->as<long long>();
  } catch (const YAML::Exception&) {
    fail("expected an integer, got " + describe_node(*node_));
  }
  if (value < lower || value > upper) {
    fail("= " + printable_value(node_->Scalar()) + ": must be in [" + std::to_string(lower) + ", " +
         std::to_string(upper) + "]");
  }
  return static_cast<int>(value);
}

bool ConfigNode::as_bool() const {
  mark_read();
  if (!node_->IsScalar()) fail("expected true or false, got " + describe_node(*node_));
  try {
    return node_->as<bool>();
  } catch (const YAML::Exception&) {
    fail("expected true or false, got " + describe_node(*node_));
  }
}

std::string ConfigNode::as_string() const {
  mark_read();
  if (!node_->IsScalar()) fail("expected a string, got " + describe_node(*node_));
  return node_->Scalar();
}

std::vector<double> ConfigNode::as_doubles(std::size_t expected_size, const Bound& bound) const {
  mark_read();
  if (!node_->IsSequence()) {
    fail(expected_size > 0
             ? "expected a list of " + std::to_string(expected_size) + " numbers, got " + describe_node(*node_)
             : "expected a list of numbers, got " + describe_node(*node_));
  }
  if (expected_size > 0 && node_->size() != expected_size) {
    fail("expected a list of " + std::to_string(expected_size) + " numbers, got " +
         std::to_string(node_->size()));
  }
  std::vector<double> values;
  values.reserve(node_->size());
  for (std::size_t i = 0; i < node_->size(); ++i) values.push_back(at(i).as_double(bound));
  return values;
}

std::string ConfigNode::as_choice(std::initializer_list<const char*> allowed) const {
  return as_choice(std::vector<std::string>(allowed.begin(), allowed.end()));
}

std::string ConfigNode::as_choice(const std::vector<std::string>& allowed) const {
  const std::string value = as_string();
  std::string listing;
  for (const std::string& option : allowed) {
    if (value == option) return value;
    listing += listing.empty() ? "" : ", ";
    listing += option;
  }
  fail("= '" + printable_value(value) + "': must be one of: " + listing);
}

double ConfigNode::get_double(const std::string& key, const Bound& bound) const {
  return child(key).as_double(bound);
}
double ConfigNode::get_double_or(const std::string& key, double fallback, const Bound& bound) const {
  const auto value = optional_child(key);
  return value ? value->as_double(bound) : fallback;
}
int ConfigNode::get_int(const std::string& key, int lower, int upper) const {
  return child(key).as_int(lower, upper);
}
int ConfigNode::get_int_or(const std::string& key, int fallback, int lower, int upper) const {
  const auto value = optional_child(key);
  return value ? value->as_int(lower, upper) : fallback;
}
bool ConfigNode::get_bool(const std::string& key) const { return child(key).as_bool(); }
bool ConfigNode::get_bool_or(const std::string& key, bool fallback) const {
  const auto value = optional_child(key);
  return value ? value->as_bool() : fallback;
}
std::string ConfigNode::get_string(const std::string& key) const { return child(key).as_string(); }
std::string ConfigNode::get_string_or(const std::string& key, const std::string& fallback) const {
  const auto value = optional_child(key);
  return value ? value->as_string() : fallback;
}
std::vector<double> ConfigNode::get_doubles(const std::string& key, std::size_t expected_size,
                                            const Bound& bound) const {
  return child(key).as_doubles(expected_size, bound);
}
std::string ConfigNode::get_choice(const std::string& key, std::initializer_list<const char*> allowed) const {
  return child(key).as_choice(allowed);
}
std::string ConfigNode::get_choice_or(const std::string& key, std::initializer_list<const char*> allowed,
                                      const std::string& fallback) const {
  const auto value = optional_child(key);
  return value ? value->as_choice(allowed) : fallback;
}

void ConfigNode::fail(const std::string& what_at_any_path) const {
  // A struct's own message may already name this path (SolverConfig::validate names
  // "controller.solver.backend"): said once, not twice.
  const std::string own_path = path_ + ": ";
  const std::string what = !path_.empty() && what_at_any_path.rfind(own_path, 0) == 0
                               ? what_at_any_path.substr(own_path.size())
                               : what_at_any_path;
  // Keys were checked for UTF-8 at parse time, but may still be long or hold a newline.
  const std::string source = printable_value(document_->source, std::string::npos);
  const std::string where = path_.empty() ? source : source + ": " + printable_value(path_, 2 * kMaxEchoedValueChars);
  // "= value: rule" reads best glued to the path; everything else after a colon.
  throw ConfigError(what.rfind("= ", 0) == 0 ? where + " " + what : where + ": " + what);
}

void ConfigNode::fail_at(const std::string& key, const std::string& what) const {
  ConfigNode(document_, YAML::Node(), child_path(key)).fail(what);
}

void ConfigNode::expect_all_read() const {
  if (node_->IsSequence()) {
    for (std::size_t i = 0; i < node_->size(); ++i) {
      ConfigNode(document_, (*node_)[i], path_ + "[" + std::to_string(i) + "]").expect_all_read();
    }
    return;
  }
  if (!node_->IsMap()) return;
  std::set<std::string> seen;
  std::vector<std::string> read_siblings;
  for (const auto& entry : *node_) {
    const std::string key = entry.first.Scalar();
    if (document_->read_paths.count(child_path(key)) > 0) read_siblings.push_back(key);
  }
  for (const auto& entry : *node_) {
    const std::string key = entry.first.Scalar();
    if (!seen.insert(key).second) fail_at(key, "duplicate key");
    const std::string path = child_path(key);
    if (document_->read_paths.count(path) == 0) {
      std::string hint;
      std::size_t best = key.size() / 3 + 2;
      for (const std::string& candidate : read_siblings) {
        const std::size_t distance = edit_distance(key, candidate);
        if (distance < best) {
          best = distance;
          hint = " (did you mean '" + candidate + "'?)";
        }
      }
      fail_at(key, "unknown key" + hint);
    }
    ConfigNode(document_, entry.second, path).expect_all_read();
  }
}

std::string ConfigNode::to_yaml() const {
  YAML::Emitter out;
  out.SetMapFormat(YAML::Flow);
  out.SetSeqFormat(YAML::Flow);
  out << *node_;
  return printable_value(out.c_str());
}

}  // namespace swerve::config
