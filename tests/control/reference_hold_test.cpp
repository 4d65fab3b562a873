// ReferenceHold: the reference's clock runs behind t by exactly the time the reference was held.
#include "swerve/control/reference_hold.hpp"

#include <gtest/gtest.h>

namespace swerve {
namespace {

TEST(ReferenceHold, NeverHeldTheReferenceTimeIsT) {
  ReferenceHold hold;
  for (double t : {0.0, 0.05, 0.1, 7.3}) EXPECT_DOUBLE_EQ(hold.reference_time(t), t);
  EXPECT_EQ(hold.delay_s(), 0.0);
}

TEST(ReferenceHold, TheTimeFromAHeldStepToTheNextIsAddedToTheDelay) {
  // As a controller uses it: each step reads its reference time, then says whether it holds.
  // The steps at 0, 0.1 and 0.2 hold, so the step at 0.3 follows the reference 0.3 s behind.
  ReferenceHold hold;
  const double steps[] = {0.0, 0.1, 0.2, 0.3, 0.5};
  const bool holds[] = {true, true, true, false, false};
  const double expected[] = {0.0, 0.0, 0.0, 0.0, 0.2};
  for (int k = 0; k < 5; ++k) {
    EXPECT_NEAR(hold.reference_time(steps[k]), expected[k], 1e-15) << "step at t = " << steps[k];
    hold.set_held(holds[k]);
  }
  EXPECT_NEAR(hold.delay_s(), 0.3, 1e-15);
  EXPECT_FALSE(hold.held());
}

TEST(ReferenceHold, TimeThatDoesNotAdvanceAddsNothingAndResetForgetsTheDelay) {
  ReferenceHold hold;
  hold.reference_time(1.0);
  hold.set_held(true);
  EXPECT_DOUBLE_EQ(hold.reference_time(0.5), 0.5);  // t went back: nothing held, the clock follows t
  EXPECT_DOUBLE_EQ(hold.reference_time(0.5), 0.5);
  EXPECT_DOUBLE_EQ(hold.reference_time(0.7), 0.5);
  hold.reset();
  EXPECT_FALSE(hold.held());
  EXPECT_DOUBLE_EQ(hold.reference_time(2.0), 2.0);
}

}  // namespace
}  // namespace swerve
