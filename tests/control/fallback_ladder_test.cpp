// The fallback ladder's rungs: the previous plan while young enough, the baseline, a safe stop.
#include <gtest/gtest.h>

#include "swerve/control/fallback_ladder.hpp"

namespace swerve {
namespace {

FallbackSituation young_plan() {
  FallbackSituation s;
  s.plan_valid = true;
  s.plan_age = 1;
  s.max_plan_age = 5;
  s.horizon = 20;
  s.baseline_usable = true;
  s.measured_usable = true;
  return s;
}

TEST(FallbackLadder, AYoungPreviousPlanComesFirstEvenWithoutAUsableMeasurement) {
  FallbackSituation s = young_plan();
  EXPECT_EQ(choose_fallback(s), CommandSource::kPreviousPlan);
  s.measured_usable = false;
  s.baseline_usable = false;
  EXPECT_EQ(choose_fallback(s), CommandSource::kPreviousPlan);
  s.plan_age = s.max_plan_age;  // the last cycle it may stand in
  EXPECT_EQ(choose_fallback(s), CommandSource::kPreviousPlan);
}

TEST(FallbackLadder, ThePlanStepsDownWhenTooOldOrOutOfStages) {
  FallbackSituation s = young_plan();
  s.plan_age = s.max_plan_age + 1;
  EXPECT_EQ(choose_fallback(s), CommandSource::kBaseline);
  s = young_plan();
  s.max_plan_age = 50;
  s.plan_age = s.horizon;  // shifted past its last stage
  EXPECT_EQ(choose_fallback(s), CommandSource::kBaseline);
  s.plan_valid = false;
  s.plan_age = 0;
  EXPECT_EQ(choose_fallback(s), CommandSource::kBaseline);
}

TEST(FallbackLadder, TheBaselineNeedsItsPlanAndAUsableMeasurementElseASafeStop) {
  FallbackSituation s = young_plan();
  s.plan_valid = false;
  s.measured_usable = false;
  EXPECT_EQ(choose_fallback(s), CommandSource::kSafeStop);
  s.measured_usable = true;
  s.baseline_usable = false;
  EXPECT_EQ(choose_fallback(s), CommandSource::kSafeStop);
}

}  // namespace
}  // namespace swerve
