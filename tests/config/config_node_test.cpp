// ConfigNode: every error class names file, key path and value; unknown keys never pass.
#include "swerve/config/config_node.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace swerve::config {
namespace {

// Runs `body` and returns the ConfigError message it throws ("" when it throws nothing).
template <typename Body>
std::string error_of(Body body) {
  try {
    body();
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "";
}

TEST(ConfigNode, ReadsTypedValuesAlongNestedPaths) {
  const ConfigNode root = ConfigNode::parse(
      "vehicle:\n  mass: 800\n  name: agv\n  driven: true\n  axles: 5\n"
      "  modules:\n    - {position: [1.0, 0.5]}\n    - {position: [-1.0, -0.5]}\n",
      "v.yaml");
  const ConfigNode vehicle = root.child("vehicle");
  EXPECT_DOUBLE_EQ(vehicle.get_double("mass", Bound::positive()), 800.0);
  EXPECT_EQ(vehicle.get_string("name"), "agv");
  EXPECT_TRUE(vehicle.get_bool("driven"));
  EXPECT_EQ(vehicle.get_int("axles", 1, 10), 5);
  const ConfigNode modules = vehicle.child("modules");
  ASSERT_EQ(modules.size(), 2u);
  EXPECT_EQ(modules.at(1).path(), "vehicle.modules[1]");
  const auto position = modules.at(1).get_doubles("position", 2);
  EXPECT_DOUBLE_EQ(position[0], -1.0);
  EXPECT_DOUBLE_EQ(position[1], -0.5);
  EXPECT_NO_THROW(modules.at(0).get_doubles("position", 2));
  EXPECT_NO_THROW(root.expect_all_read());
}

TEST(ConfigNode, OptionalKeysFallBackToTheirDocumentedDefault) {
  const ConfigNode root = ConfigNode::parse("a: 1\n", "f.yaml");
  EXPECT_DOUBLE_EQ(root.get_double_or("missing", 2.5), 2.5);
  EXPECT_EQ(root.get_int_or("a", 7), 1);
  EXPECT_FALSE(root.optional_child("missing").has_value());
}

TEST(ConfigNode, WrongListLengthNamesPathAndCounts) {
  const ConfigNode root =
      ConfigNode::parse("vehicle:\n  modules:\n    - {position: [1, 2]}\n    - {position: [1, 2]}\n"
                        "    - {position: [1, 2, 3]}\n",
                        "configs/vehicles/x.yaml");
  const std::string message = error_of([&] {
    root.child("vehicle").child("modules").at(2).get_doubles("position", 2);
  });
  EXPECT_EQ(message,
            "configs/vehicles/x.yaml: vehicle.modules[2].position: expected a list of 2 numbers, got 3");
}

TEST(ConfigNode, OutOfRangeValueNamesValueAndRule) {
  const ConfigNode root = ConfigNode::parse("controller:\n  horizon: 0\n  mass: -3.5\n", "c.yaml");
  EXPECT_EQ(error_of([&] { root.child("controller").get_int("horizon", 1, 1000); }),
            "c.yaml: controller.horizon = 0: must be in [1, 1000]");
  EXPECT_EQ(error_of([&] { root.child("controller").get_double("mass", Bound::positive()); }),
            "c.yaml: controller.mass = -3.5: must be > 0");
}

TEST(ConfigNode, NonFiniteNumbersAreRejected) {
  const ConfigNode root = ConfigNode::parse("a: .nan\nb: .inf\nc: -.inf\n", "n.yaml");
  EXPECT_EQ(error_of([&] { root.get_double("a"); }), "n.yaml: a = .nan: must be a finite number");
  EXPECT_EQ(error_of([&] { root.get_double("b"); }), "n.yaml: b = .inf: must be a finite number");
  EXPECT_NE(error_of([&] { root.get_double("c"); }), "");
}

TEST(ConfigNode, WrongTypesAreRejectedWithWhatWasFound) {
  const ConfigNode root =
      ConfigNode::parse("mass: heavy\nlist: [1, x]\nflag: maybe\nn: 1.5\nmap: {a: 1}\n", "t.yaml");
  EXPECT_EQ(error_of([&] { root.get_double("mass"); }), "t.yaml: mass: expected a number, got 'heavy'");
  EXPECT_EQ(error_of([&] { root.get_doubles("list"); }), "t.yaml: list[1]: expected a number, got 'x'");
  EXPECT_EQ(error_of([&] { root.get_bool("flag"); }), "t.yaml: flag: expected true or false, got 'maybe'");
  EXPECT_EQ(error_of([&] { root.get_int("n"); }), "t.yaml: n: expected an integer, got '1.5'");
  EXPECT_EQ(error_of([&] { root.get_double("map"); }), "t.yaml: map: expected a number, got a map");
  EXPECT_EQ(error_of([&] { root.get_doubles("mass", 2); }),
            "t.yaml: mass: expected a list of 2 numbers, got 'heavy'");
}

TEST(ConfigNode, MissingRequiredKeyIsNamed) {
  const ConfigNode root = ConfigNode::parse("vehicle:\n  name: a\n", "m.yaml");
  EXPECT_EQ(error_of([&] { root.child("vehicle").get_double("mass"); }),
            "m.yaml: vehicle.mass: required key is missing");
}

TEST(ConfigNode, ChoiceListsTheAllowedValues) {
  const ConfigNode root = ConfigNode::parse("backend: ipot\n", "b.yaml");
  EXPECT_EQ(error_of([&] { root.get_choice("backend", {"sa", "ipopt"}); }),
            "b.yaml: backend = 'ipot': must be one of: sa, ipopt");
}

TEST(ConfigNode, UnknownKeyIsAnErrorWithASuggestion) {
  const ConfigNode root = ConfigNode::parse("vehicle:\n  mass: 1\n  masss: 2\n", "u.yaml");
  root.child("vehicle").get_double("mass");
  EXPECT_EQ(error_of([&] { root.expect_all_read(); }),
            "u.yaml: vehicle.masss: unknown key (did you mean 'mass'?)");
}

TEST(ConfigNode, UnknownKeyInsideAListElementIsFound) {
  const ConfigNode root =
      ConfigNode::parse("modules:\n  - {position: [0, 1]}\n  - {position: [0, 2], typo: 1}\n", "l.yaml");
  const ConfigNode modules = root.child("modules");
  for (std::size_t i = 0; i < modules.size(); ++i) modules.at(i).get_doubles("position", 2);
  EXPECT_EQ(error_of([&] { root.expect_all_read(); }), "l.yaml: modules[1].typo: unknown key");
}

TEST(ConfigNode, DuplicateKeysAreRejected) {
  const ConfigNode root = ConfigNode::parse("a: 1\na: 2\n", "d.yaml");
  root.get_double("a");
  EXPECT_EQ(error_of([&] { root.expect_all_read(); }), "d.yaml: a: duplicate key");
}

TEST(ConfigNode, SyntaxErrorGivesFileLineAndColumn) {
  const std::string message = error_of([] { ConfigNode::parse("a: [1, 2\nb: 3\n", "s.yaml"); });
  EXPECT_EQ(message.rfind("s.yaml:", 0), 0u) << message;
  EXPECT_NE(message.find("YAML syntax error"), std::string::npos) << message;
}

TEST(ConfigNode, TopLevelMustBeAMap) {
  EXPECT_EQ(error_of([] { ConfigNode::parse("- 1\n- 2\n", "top.yaml"); }),
            "top.yaml: expected a map of keys at the top level, got a list of 2");
  EXPECT_NE(error_of([] { ConfigNode::parse("", "empty.yaml"); }), "");
}

TEST(ConfigNode, MissingFileIsAClearError) {
  EXPECT_EQ(error_of([] { ConfigNode::load_file("/nonexistent/file.yaml"); }),
            "/nonexistent/file.yaml: cannot open the file for reading");
}

TEST(ConfigNode, BoundDescriptionsReadAsRules) {
  EXPECT_EQ(Bound::positive().describe(), "must be > 0");
  EXPECT_EQ(Bound::non_negative().describe(), "must be >= 0");
  EXPECT_EQ(Bound::closed(0, 1).describe(), "must be in [0, 1]");
  EXPECT_TRUE(Bound::half_open(0, 1).contains(1.0));
  EXPECT_FALSE(Bound::half_open(0, 1).contains(0.0));
}

}  // namespace
}  // namespace swerve::config
