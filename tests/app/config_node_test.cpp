// ConfigNode: every error class names file, key path and value; unknown keys never pass.
#include "swerve/app/config_node.hpp"
#include "support/config_errors.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace swerve::config {
namespace {

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

TEST(ConfigNode, AFailureWhoseMessageAlreadyNamesItsKeyPathSaysThePathOnce) {
  // SolverConfig::validate names "controller.solver.backend" itself; the loader fails at that key
  // with it, and the cross build (no Ceres) printed "...: controller.solver.backend:
  // controller.solver.backend: 'ceres' was not built". A message naming another path keeps it.
  const ConfigNode root = ConfigNode::parse("controller:\n  solver: {backend: ceres}\n", "c.yaml");
  const ConfigNode solver = root.child("controller").child("solver");
  EXPECT_EQ(testing::config_error_of([&] { solver.fail_at("backend", "controller.solver.backend: 'ceres' was not built (built: sa)"); }),
            "c.yaml: controller.solver.backend: 'ceres' was not built (built: sa)");
  EXPECT_EQ(testing::config_error_of([&] { solver.fail_at("backend", "SaOptions.knots = 0: must be >= 1"); }),
            "c.yaml: controller.solver.backend: SaOptions.knots = 0: must be >= 1");
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
  const std::string message = testing::config_error_of([&] {
    root.child("vehicle").child("modules").at(2).get_doubles("position", 2);
  });
  EXPECT_EQ(message,
            "configs/vehicles/x.yaml: vehicle.modules[2].position: expected a list of 2 numbers, got 3");
}

TEST(ConfigNode, OutOfRangeValueNamesValueAndRule) {
  const ConfigNode root = ConfigNode::parse("controller:\n  horizon: 0\n  mass: -3.5\n", "c.yaml");
  EXPECT_EQ(testing::config_error_of([&] { root.child("controller").get_int("horizon", 1, 1000); }),
            "c.yaml: controller.horizon = 0: must be in [1, 1000]");
  EXPECT_EQ(testing::config_error_of([&] { root.child("controller").get_double("mass", Bound::positive()); }),
            "c.yaml: controller.mass = -3.5: must be > 0");
}

TEST(ConfigNode, NonFiniteNumbersAreRejected) {
  const ConfigNode root = ConfigNode::parse("a: .nan\nb: .inf\nc: -.inf\n", "n.yaml");
  EXPECT_EQ(testing::config_error_of([&] { root.get_double("a"); }), "n.yaml: a = .nan: must be a finite number");
  EXPECT_EQ(testing::config_error_of([&] { root.get_double("b"); }), "n.yaml: b = .inf: must be a finite number");
  EXPECT_NE(testing::config_error_of([&] { root.get_double("c"); }), "");
}

TEST(ConfigNode, WrongTypesAreRejectedWithWhatWasFound) {
  const ConfigNode root =
      ConfigNode::parse("mass: heavy\nlist: [1, x]\nflag: maybe\nn: 1.5\nmap: {a: 1}\n", "t.yaml");
  EXPECT_EQ(testing::config_error_of([&] { root.get_double("mass"); }), "t.yaml: mass: expected a number, got 'heavy'");
  EXPECT_EQ(testing::config_error_of([&] { root.get_doubles("list"); }), "t.yaml: list[1]: expected a number, got 'x'");
  EXPECT_EQ(testing::config_error_of([&] { root.get_bool("flag"); }), "t.yaml: flag: expected true or false, got 'maybe'");
  EXPECT_EQ(testing::config_error_of([&] { root.get_int("n"); }), "t.yaml: n: expected an integer, got '1.5'");
  EXPECT_EQ(testing::config_error_of([&] { root.get_double("map"); }), "t.yaml: map: expected a number, got a map");
  EXPECT_EQ(testing::config_error_of([&] { root.get_doubles("mass", 2); }),
            "t.yaml: mass: expected a list of 2 numbers, got 'heavy'");
}

TEST(ConfigNode, MissingRequiredKeyIsNamed) {
  const ConfigNode root = ConfigNode::parse("vehicle:\n  name: a\n", "m.yaml");
  EXPECT_EQ(testing::config_error_of([&] { root.child("vehicle").get_double("mass"); }),
            "m.yaml: vehicle.mass: required key is missing");
}

TEST(ConfigNode, ChoiceListsTheAllowedValues) {
  const ConfigNode root = ConfigNode::parse("backend: ipot\n", "b.yaml");
  EXPECT_EQ(testing::config_error_of([&] { root.get_choice("backend", {"sa", "ipopt"}); }),
            "b.yaml: backend = 'ipot': must be one of: sa, ipopt");
}

TEST(ConfigNode, UnknownKeyIsAnErrorWithASuggestion) {
  const ConfigNode root = ConfigNode::parse("vehicle:\n  mass: 1\n  masss: 2\n", "u.yaml");
  root.child("vehicle").get_double("mass");
  EXPECT_EQ(testing::config_error_of([&] { root.expect_all_read(); }),
            "u.yaml: vehicle.masss: unknown key (did you mean 'mass'?)");
}

TEST(ConfigNode, UnknownKeyInsideAListElementIsFound) {
  const ConfigNode root =
      ConfigNode::parse("modules:\n  - {position: [0, 1]}\n  - {position: [0, 2], typo: 1}\n", "l.yaml");
  const ConfigNode modules = root.child("modules");
  for (std::size_t i = 0; i < modules.size(); ++i) modules.at(i).get_doubles("position", 2);
  EXPECT_EQ(testing::config_error_of([&] { root.expect_all_read(); }), "l.yaml: modules[1].typo: unknown key");
}

TEST(ConfigNode, DuplicateKeysAreRejected) {
  const ConfigNode root = ConfigNode::parse("a: 1\na: 2\n", "d.yaml");
  root.get_double("a");
  EXPECT_EQ(testing::config_error_of([&] { root.expect_all_read(); }), "d.yaml: a: duplicate key");
}

TEST(ConfigNode, SyntaxErrorGivesFileLineAndColumn) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("a: [1, 2\nb: 3\n", "s.yaml"); });
  EXPECT_EQ(message.rfind("s.yaml:", 0), 0u) << message;
  EXPECT_NE(message.find("YAML syntax error"), std::string::npos) << message;
}

TEST(ConfigNode, TopLevelMustBeAMap) {
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::parse("- 1\n- 2\n", "top.yaml"); }),
            "top.yaml: expected a map of keys at the top level, got a list of 2");
  EXPECT_NE(testing::config_error_of([] { ConfigNode::parse("", "empty.yaml"); }), "");
}

TEST(ConfigNode, MissingFileIsAClearError) {
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::load_file("/nonexistent/file.yaml"); }),
            "/nonexistent/file.yaml: cannot open the file for reading");
}

TEST(ConfigNode, BoundDescriptionsReadAsRules) {
  EXPECT_EQ(Bound::positive().describe(), "must be > 0");
  EXPECT_EQ(Bound::non_negative().describe(), "must be >= 0");
  EXPECT_EQ(Bound::closed(0, 1).describe(), "must be in [0, 1]");
  EXPECT_TRUE(Bound::half_open(0, 1).contains(1.0));
  EXPECT_FALSE(Bound::half_open(0, 1).contains(0.0));
}


// Issue 14 item 5: hostile files and text fail at load, in one line naming file and key.

TEST(ConfigNode, RejectsASecondYamlDocument) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("a: 1\n---\nb: 2\n", "two.yaml"); });
  EXPECT_NE(message.find("two.yaml:3: a second YAML document"), std::string::npos) << message;
}

// Found by tests/fuzz/config_fuzzer: yaml-cpp 0.7's LoadAll never returns on a lone ',' (it hands
// back null documents at the same place until memory runs out, jbeder/yaml-cpp#1040).
TEST(ConfigNode, AStrayCommaIsASyntaxErrorNotAnEndlessParse) {
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::parse(",", "comma.yaml"); }),
            "comma.yaml:1:1: YAML syntax error: unexpected ','");
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::parse("  ,a: 1\n", "comma.yaml"); }),
            "comma.yaml:1:3: YAML syntax error: unexpected ','");
  const std::string message = testing::config_error_of([] { ConfigNode::parse("a: 1\n---\n,\n", "comma.yaml"); });
  EXPECT_NE(message.find("comma.yaml:"), std::string::npos) << message;
}

// Found by tests/fuzz/config_fuzzer: a list that contains itself through an alias sent the text
// check into endless recursion (a stack overflow).
TEST(ConfigNode, RejectsAnAliasOfAListInsideItself) {
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::parse("a: 1\nc: &c [1, *c]\n", "cycle.yaml"); }),
            "cycle.yaml: c[1]: an alias of a list or map that contains it: config values cannot nest in themselves");
  EXPECT_EQ(testing::config_error_of([] { ConfigNode::parse("m: &m {k: *m}\n", "cycle.yaml"); }),
            "cycle.yaml: m.k: an alias of a list or map that contains it: config values cannot nest in themselves");
  // Aliases that repeat a node without nesting it in itself stay fine.
  EXPECT_NO_THROW(ConfigNode::parse("a: &a [1, 2]\nb: [*a, *a]\n", "shared.yaml"));
}

TEST(ConfigNode, RejectsNestingDeeperThanTheLimit) {
  const auto nested = [](std::size_t depth) {
    return "a: " + std::string(depth, '[') + std::string(depth, ']') + "\n";
  };
  EXPECT_NO_THROW(ConfigNode::parse(nested(kMaxConfigDepth - 1), "deep.yaml"));  // + the root map
  const std::string message = testing::config_error_of([&] { ConfigNode::parse(nested(kMaxConfigDepth), "deep.yaml"); });
  EXPECT_NE(message.find("deep.yaml: a"), std::string::npos) << message;
  EXPECT_NE(message.find(": nested deeper than 64 lists and maps"), std::string::npos) << message;
}

TEST(ConfigNode, RejectsAnEmptySecondYamlDocumentToo) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("a: 1\n---\n", "two.yaml"); });
  EXPECT_NE(message.find("two.yaml:3: a second YAML document"), std::string::npos) << message;
}

TEST(ConfigNode, AcceptsExplicitDocumentMarkersAroundOneDocument) {
  EXPECT_NO_THROW(ConfigNode::parse("---\na: 1\n...\n", "one.yaml"));
}

TEST(ConfigNode, RejectsAnEmptyDocumentNamingTheFile) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("", "empty.yaml"); });
  EXPECT_NE(message.find("empty.yaml: the file is empty"), std::string::npos) << message;
}

TEST(ConfigNode, RejectsInvalidUtf8InAValueNamingTheKeyPath) {
  const std::string message =
      testing::config_error_of([] { ConfigNode::parse("scenario:\n  description: \"caf\xe9\"\n", "s.yaml"); });
  EXPECT_NE(message.find("s.yaml: scenario.description = 'caf\\xe9': the value is not valid UTF-8 (byte 0xe9 at "
                         "offset 3)"),
            std::string::npos)
      << message;
}

TEST(ConfigNode, RejectsInvalidUtf8InAKey) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("vehicle:\n  m\xffss: 1\n", "v.yaml"); });
  EXPECT_NE(message.find("v.yaml: vehicle.m\\xffss = 'm\\xffss': the key is not valid UTF-8"), std::string::npos)
      << message;
}

TEST(ConfigNode, RejectsInvalidUtf8InsideAList) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("a:\n  - ok\n  - \"\xc3\"\n", "l.yaml"); });
  EXPECT_NE(message.find("l.yaml: a[1] = "), std::string::npos) << message;
}

TEST(ConfigNode, AcceptsMultiByteUtf8Text) {
  const ConfigNode root = ConfigNode::parse("a: \"caf\xc3\xa9 \xe2\x86\x92 \xf0\x9f\x9a\x97\"\n", "u.yaml");
  EXPECT_EQ(root.get_string("a"), "caf\xc3\xa9 \xe2\x86\x92 \xf0\x9f\x9a\x97");
}

TEST(ConfigNode, RejectsAKeyThatIsNotAPlainString) {
  const std::string message = testing::config_error_of([] { ConfigNode::parse("target:\n  ? [a, b]\n  : 1\n", "k.yaml"); });
  EXPECT_NE(message.find("k.yaml: target = a list of 2: a key must be a plain string"), std::string::npos) << message;
}

TEST(ConfigNode, RejectsADocumentThatAliasesExpandPastTheValueLimit) {
  std::string text = "a0: &a0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int level = 1; level <= 6; ++level) {
    const std::string previous = "*a" + std::to_string(level - 1);
    text += "a" + std::to_string(level) + ": &a" + std::to_string(level) + " [";
    for (int i = 0; i < 10; ++i) text += (i ? ", " : "") + previous;
    text += "]\n";
  }
  const std::string message = testing::config_error_of([&] { ConfigNode::parse(text, "bomb.yaml"); });
  EXPECT_NE(message.find("bomb.yaml: more than 1000000 values once anchors and aliases are expanded"),
            std::string::npos)
      << message;
}

TEST(ConfigNode, ShortensALongEchoedValue) {
  const std::string long_value(100000, 'x');
  const std::string message =
      testing::config_error_of([&] { ConfigNode::parse("a: " + long_value + "\n", "long.yaml").get_double("a"); });
  EXPECT_NE(message.find("long.yaml: a: expected a number, got '" + std::string(kMaxEchoedValueChars, 'x') +
                         "... (100000 bytes)'"),
            std::string::npos)
      << message;
  EXPECT_LT(message.size(), 200u);
}

TEST(ConfigNode, KeepsAMultiLineValueOnOneLine) {
  const std::string message =
      testing::config_error_of([] { ConfigNode::parse("a: |\n  1\n  2\n", "m.yaml").get_double("a", Bound::positive()); });
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_NE(message.find("got '1\\n2\\n'"), std::string::npos) << message;
}

TEST(ConfigNode, ShortensALongValueInAChoiceError) {
  const std::string message = testing::config_error_of(
      [] { ConfigNode::parse("a: " + std::string(5000, 'y') + "\n", "c.yaml").get_choice("a", {"sa", "ipopt"}); });
  EXPECT_NE(message.find("... (5000 bytes)': must be one of: sa, ipopt"), std::string::npos) << message;
}

TEST(ConfigNode, LoadFileRejectsADirectoryNamingIt) {
  const std::string directory = SWERVE_SOURCE_DIR "/tests/app";
  const std::string message = testing::config_error_of([&] { ConfigNode::load_file(directory); });
  EXPECT_EQ(message, directory + ": a directory, not a regular file: give a YAML file");
}

TEST(ConfigNode, LoadFileRejectsADeviceWithoutReadingIt) {
  const std::string message = testing::config_error_of([] { ConfigNode::load_file("/dev/zero"); });
  EXPECT_EQ(message, "/dev/zero: a character device, not a regular file: give a YAML file");
}

TEST(ConfigNode, LoadFileRejectsAFileOverTheSizeLimit) {
  const std::string path = SWERVE_BINARY_DIR "/config_node_test_oversized.yaml";
  {
    std::ofstream out(path);
    out << "a:\n";
    for (std::size_t written = 3; written <= kMaxConfigFileBytes; written += 6) out << "  - 1\n";
  }
  const std::string message = testing::config_error_of([&] { ConfigNode::load_file(path); });
  std::filesystem::remove(path);
  EXPECT_NE(message.find(path + ": "), std::string::npos) << message;
  EXPECT_NE(message.find(" bytes: config files are limited to 1 MiB (1048576 bytes)"), std::string::npos) << message;
}

TEST(ConfigNode, LoadFileAcceptsAFileAtTheSizeLimit) {
  const std::string path = SWERVE_BINARY_DIR "/config_node_test_at_limit.yaml";
  {
    std::ofstream out(path);
    out << "a: 1\n" << std::string(kMaxConfigFileBytes - 5, '#');  // a comment fills the rest
  }
  ASSERT_EQ(std::filesystem::file_size(path), kMaxConfigFileBytes);
  EXPECT_NO_THROW(ConfigNode::load_file(path));
  std::filesystem::remove(path);
}

TEST(ConfigError, KeepsItsMessageToOneBoundedLine) {
  const ConfigError error("f.yaml: a = " + std::string(5000, 'z') + "\nsecond line");
  const std::string message = error.what();
  EXPECT_EQ(message.find('\n'), std::string::npos);
  EXPECT_LT(message.size(), kMaxConfigErrorChars + 40);
}

TEST(ConfigError, InvalidFieldShortensTheValue) {
  const std::string message = testing::config_error_of([] { throw_invalid_field("Options", "name", std::string(300, 'n'), "bad"); });
  EXPECT_EQ(message, "Options.name = " + std::string(kMaxEchoedValueChars, 'n') + "... (300 bytes): bad");
}

}  // namespace
}  // namespace swerve::config
