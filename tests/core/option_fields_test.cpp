// An options table's checks (check_fields) on a struct of every field kind: each bound's edges, a
// NaN and an infinity, the choices, the note, and the message's shape. The loaders' side of the
// same tables is in app/option_reader_test.cpp.
#include "swerve/core/option_fields.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string>

namespace swerve {
namespace {

struct Sample {
  double gain = 0.5;
  double mass = 1.0;
  int count = 3;
  bool on = true;
  Eigen::Vector3d weights{1.0, 2.0, 3.0};
  std::string mode = "fast";
  std::optional<double> height;  // unset by default

  static const OptionFields<Sample>& fields() {
    static const OptionFields<Sample> table{
        {"gain", &Sample::gain, Bound::half_open(0.0, 1.0)},
        {"mass", &Sample::mass, Bound::positive(), {}, nullptr, "(kg)"},
        {"count", &Sample::count, Bound::closed(1, 16)},
        {"on", &Sample::on},
        {"weights", &Sample::weights, Bound::non_negative()},
        {"mode", &Sample::mode, Bound::any(), {"fast", "exact"}, "method"},
        {"height", &Sample::height, Bound::positive(), {}, nullptr, "(m)"},
    };
    return table;
  }
};

std::string message_of(const Sample& sample) {
  try {
    check_fields("Sample", sample, Sample::fields());
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "accepted";
}

template <typename Set>
std::string with(Set set) {
  Sample sample;
  set(sample);
  return message_of(sample);
}

TEST(OptionFields, AcceptsTheDefaultsAndEveryClosedEdge) {
  EXPECT_EQ(message_of(Sample{}), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.gain = 1.0; }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.count = 1; }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.count = 16; }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.weights.setZero(); }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.mode = "exact"; }), "accepted");
}

TEST(OptionFields, RejectsEachOpenEdgeAndBeyondNamingTheFieldValueAndRule) {
  EXPECT_EQ(with([](Sample& s) { s.gain = 0.0; }), "Sample.gain = 0: must be in (0, 1]");
  EXPECT_EQ(with([](Sample& s) { s.gain = 1.5; }), "Sample.gain = 1.5: must be in (0, 1]");
  EXPECT_EQ(with([](Sample& s) { s.mass = 0.0; }), "Sample.mass = 0: must be finite and > 0 (kg)");
  EXPECT_EQ(with([](Sample& s) { s.count = 0; }), "Sample.count = 0: must be in [1, 16]");
  EXPECT_EQ(with([](Sample& s) { s.count = 17; }), "Sample.count = 17: must be in [1, 16]");
  EXPECT_EQ(with([](Sample& s) { s.weights.y() = -1.0; }), "Sample.weights = [1, -1, 3]: must be finite and >= 0 on every axis");
  EXPECT_EQ(with([](Sample& s) { s.mode = "slow"; }), "Sample.mode = slow: must be fast or exact");
}

TEST(OptionFields, RejectsNaNAndInfinityEvenWhereTheBoundIsOpenTowardsIt) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(with([](Sample& s) { s.mass = kInf; }), "Sample.mass = inf: must be finite and > 0 (kg)");
  EXPECT_EQ(with([](Sample& s) { s.gain = std::nan(""); }), "Sample.gain = nan: must be in (0, 1]");
  EXPECT_EQ(with([](Sample& s) { s.weights.z() = kInf; }).rfind("Sample.weights = ", 0), 0u);
}

TEST(OptionFields, AnOptionalNumberIsCheckedOnlyWhenSet) {
  EXPECT_EQ(with([](Sample& s) { s.height = std::nullopt; }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.height = 0.4; }), "accepted");
  EXPECT_EQ(with([](Sample& s) { s.height = 0.0; }), "Sample.height = 0: must be finite and > 0 (m)");
  EXPECT_EQ(with([](Sample& s) { s.height = std::nan(""); }), "Sample.height = nan: must be finite and > 0 (m)");
}

TEST(OptionFields, ChecksTheFieldsInTheTablesOrder) {
  EXPECT_EQ(with([](Sample& s) {
              s.count = 0;
              s.gain = 2.0;
            }),
            "Sample.gain = 2: must be in (0, 1]");
}

TEST(OptionFields, BoundsDescribeThemselvesAsTheLoadersAndValidateSayThem) {
  EXPECT_EQ(Bound::open(0, 1).describe(), "must be in (0, 1)");
  EXPECT_EQ(Bound::right_open(0, 0.5).describe(), "must be in [0, 0.5)");
  EXPECT_EQ(Bound::at_least(2).describe(), "must be >= 2");
  EXPECT_EQ(Bound::positive().describe_finite(), "must be finite and > 0");
  EXPECT_EQ(Bound::closed(0, 1).describe_finite(), "must be in [0, 1]");
  EXPECT_EQ(Bound::any().describe(), "must be a finite number");
  EXPECT_FALSE(Bound::any().contains(std::nan("")));
  EXPECT_TRUE(Bound::any().contains(1e300));
}

TEST(OptionFields, AFieldsYamlKeyIsItsNameUnlessTheTableGivesOne) {
  EXPECT_STREQ(Sample::fields()[0].yaml_key(), "gain");
  EXPECT_STREQ(Sample::fields()[5].yaml_key(), "method");
}

}  // namespace
}  // namespace swerve
