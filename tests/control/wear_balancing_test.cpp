// Wear balancing's weights and options (wear_balancing.hpp), worked by hand on two modules.
#include "swerve/control/wear_balancing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "support/config_errors.hpp"

namespace swerve {
namespace {

TEST(WearBalancingWeights, OnTwoEquallyLoadedModulesTheWeightsAreTheWearOverItsMeanToTheExponent) {
  const double wear[2] = {100.0, 300.0}, loads[2] = {0.5, 0.5};
  double weights[2];
  WearBalancingOptions options;  // exponent 1, bounds [0.25, 4]
  wear_balancing_weights(options, wear, loads, 2, weights);
  // Mean 200: (0.5, 1.5), whose mean is already 1.
  EXPECT_DOUBLE_EQ(weights[0], 0.5);
  EXPECT_DOUBLE_EQ(weights[1], 1.5);
  // Squared: (0.25, 2.25), mean 1.25, so (0.2, 1.8); 0.2 is raised to the floor 0.25.
  options.exponent = 2.0;
  wear_balancing_weights(options, wear, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[0], 0.25);
  EXPECT_DOUBLE_EQ(weights[1], 1.8);
  // And held under the ceiling.
  options.max_weight = 1.5;
  wear_balancing_weights(options, wear, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[1], 1.5);
}

TEST(WearBalancingWeights, TheMeanIsWeighedByEachModulesShareOfTheLoad) {
  // Loads (1/4, 3/4): mean wear 25 + 225 = 250, weights (0.4, 1.2), whose load-weighted mean is 1.
  const double wear[2] = {100.0, 300.0}, loads[2] = {0.25, 0.75};
  double weights[2];
  wear_balancing_weights(WearBalancingOptions{}, wear, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[0], 0.4);
  EXPECT_DOUBLE_EQ(weights[1], 1.2);
  EXPECT_DOUBLE_EQ(0.25 * weights[0] + 0.75 * weights[1], 1.0);
}

TEST(WearBalancingWeights, NewTiresAndEvenlyWornOnesWeighOneEach) {
  const double loads[2] = {0.5, 0.5};
  double weights[2] = {-1.0, -1.0};
  const double fresh[2] = {0.0, 0.0};
  wear_balancing_weights(WearBalancingOptions{}, fresh, loads, 2, weights);
  EXPECT_EQ(weights[0], 1.0);
  EXPECT_EQ(weights[1], 1.0);
  const double even[2] = {70.0, 70.0};
  wear_balancing_weights(WearBalancingOptions{}, even, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[0], 1.0);
  EXPECT_DOUBLE_EQ(weights[1], 1.0);
}

TEST(WearBalancingWeights, AnOffsetMakesTiresThatHaveWornLittleWeighNearlyAlike) {
  // Offset 100 on (1, 3): ratios 101 / 102 and 103 / 102, scaled to mean 1 (their mean is 1).
  const double wear[2] = {1.0, 3.0}, loads[2] = {0.5, 0.5};
  double weights[2];
  WearBalancingOptions options;
  options.wear_offset = 100.0;
  wear_balancing_weights(options, wear, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[0], 101.0 / 102.0);
  EXPECT_DOUBLE_EQ(weights[1], 103.0 / 102.0);
  options.wear_offset = 0.0;  // without it the same millijoules set a wide spread: (0.5, 1.5)
  wear_balancing_weights(options, wear, loads, 2, weights);
  EXPECT_DOUBLE_EQ(weights[0], 0.5);
}

TEST(WearBalancingWeights, WearNearTheLargestDoubleGivesFiniteWeights) {
  const double huge = std::numeric_limits<double>::max();
  const double wear[2] = {huge, 0.5 * huge}, loads[2] = {0.5, 0.5};
  double weights[2];
  wear_balancing_weights(WearBalancingOptions{}, wear, loads, 2, weights);
  // Mean 0.75 huge: (4 / 3, 2 / 3).
  EXPECT_DOUBLE_EQ(weights[0], 4.0 / 3.0);
  EXPECT_DOUBLE_EQ(weights[1], 2.0 / 3.0);
}

TEST(WearBalancingOptions, RefusesBadValuesNamingTheField) {
  const auto refusal = [](void (*spoil)(WearBalancingOptions&)) {
    WearBalancingOptions options;
    spoil(options);
    return testing::config_error_of([&] { options.validate(); });
  };
  EXPECT_NE(refusal([](WearBalancingOptions& o) { o.exponent = -1.0; }).find("exponent = -1"),
            std::string::npos);
  EXPECT_NE(refusal([](WearBalancingOptions& o) { o.exponent = std::nan(""); }).find("exponent"),
            std::string::npos);
  EXPECT_NE(refusal([](WearBalancingOptions& o) { o.min_weight = 0.0; }).find("min_weight = 0"),
            std::string::npos);
  EXPECT_NE(refusal([](WearBalancingOptions& o) { o.max_weight = 0.5; }).find("max_weight = 0.5"),
            std::string::npos);
  EXPECT_NE(refusal([](WearBalancingOptions& o) { o.wear_offset = -1.0; }).find("wear_offset = -1"),
            std::string::npos);
  EXPECT_NO_THROW(WearBalancingOptions{}.validate());
}

}  // namespace
}  // namespace swerve
