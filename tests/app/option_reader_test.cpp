// Reading an options table's fields from YAML (read_fields): present keys read with their type,
// absent ones left alone, a table's YAML key used where it differs from the field's name, a value
// outside the table's rule rejected where it was read, naming the file, key path and value, and a
// block that is not a map refused.
#include "swerve/app/option_reader.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <string>

namespace swerve {
namespace {

struct Sample {
  double gain = 0.5;
  int count = 3;
  int odd = 5;
  bool on = false;
  Eigen::Vector3d weights{1.0, 2.0, 3.0};
  std::string mode = "fast";
  std::optional<double> height;

  static const OptionFields<Sample>& fields() {
    static const OptionFields<Sample> table{
        {"gain", &Sample::gain, Bound::half_open(0.0, 1.0)},
        {"count", &Sample::count, Bound::closed(1, 16)},
        {"odd", &Sample::odd, Bound::open(0.5, 9.5)},
        {"on", &Sample::on},
        {"weights", &Sample::weights, Bound::non_negative()},
        {"mode", &Sample::mode, Bound::any(), {"fast", "exact"}, "method"},
        {"height", &Sample::height, Bound::positive()},
    };
    return table;
  }
};

Sample read(const std::string& block) {
  const config::ConfigNode root = config::ConfigNode::parse("sample:\n" + block, "s.yaml");
  Sample sample;
  config::read_fields(root.child("sample"), Sample::fields(), &sample);
  root.expect_all_read();
  return sample;
}

std::string error_of(const std::string& block) {
  try {
    read(block);
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "accepted";
}

TEST(OptionReader, ReadsThePresentKeysByTypeAndLeavesTheOthers) {
  const Sample s = read("  gain: 1\n  on: true\n  weights: [0, 0.5, 4]\n  method: exact\n");
  EXPECT_EQ(s.gain, 1.0);
  EXPECT_EQ(s.count, 3);
  EXPECT_TRUE(s.on);
  EXPECT_EQ(s.weights, Eigen::Vector3d(0.0, 0.5, 4.0));
  EXPECT_EQ(s.mode, "exact");
}

TEST(OptionReader, RejectsAValueOutsideTheTablesRuleNamingFileKeyAndValue) {
  EXPECT_EQ(error_of("  gain: 0\n"), "s.yaml: sample.gain = 0: must be in (0, 1]");
  EXPECT_EQ(error_of("  count: 17\n"), "s.yaml: sample.count = 17: must be in [1, 16]");
  EXPECT_EQ(error_of("  weights: [1, -1, 1]\n").rfind("s.yaml: sample.weights", 0), 0u);
  EXPECT_EQ(error_of("  method: slow\n"), "s.yaml: sample.method = 'slow': must be one of: fast, exact");
  EXPECT_NE(error_of("  count: 2.5\n").find("expected an integer"), std::string::npos);
  EXPECT_NE(error_of("  gain: .nan\n").find("must be a finite number"), std::string::npos);
  // The table's name for it is not its YAML key: an unknown key.
  EXPECT_NE(error_of("  mode: exact\n").find("sample.mode"), std::string::npos);
}

TEST(OptionReader, SetsAnOptionalNumberOnlyWhenItsKeyIsPresent) {
  EXPECT_FALSE(read("  gain: 1\n").height.has_value());
  EXPECT_EQ(read("  height: 0.4\n").height, std::optional<double>(0.4));
  EXPECT_EQ(error_of("  height: 0\n"), "s.yaml: sample.height = 0: must be > 0");
}

TEST(OptionReader, RefusesABlockThatIsNotAMap) {
  for (const char* text : {"sample: 5\n", "sample:\n", "sample: [1, 2]\n"}) {
    SCOPED_TRACE(text);
    const config::ConfigNode root = config::ConfigNode::parse(text, "s.yaml");
    Sample sample;
    try {
      config::read_fields(root.child("sample"), Sample::fields(), &sample);
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("s.yaml: sample: expected a map", 0), 0u) << e.what();
    }
  }
}

TEST(OptionReader, AnIntegerFieldsOpenBoundTakesTheIntegersInside) {
  EXPECT_EQ(read("  odd: 1\n").odd, 1);
  EXPECT_EQ(read("  odd: 9\n").odd, 9);
  EXPECT_EQ(error_of("  odd: 0\n"), "s.yaml: sample.odd = 0: must be in [1, 9]");
  EXPECT_EQ(error_of("  odd: 10\n"), "s.yaml: sample.odd = 10: must be in [1, 9]");
}

}  // namespace
}  // namespace swerve
