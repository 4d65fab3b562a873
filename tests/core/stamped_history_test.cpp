// core/stamped_history.hpp: newest first, the oldest overwritten once full, found by time within a
// tolerance, empty again after clear().
#include "swerve/core/stamped_history.hpp"

#include <gtest/gtest.h>

namespace swerve {
namespace {

struct Stamped {
  double t = 0.0;
  int value = 0;
};

TEST(StampedHistory, KeepsTheNewestFirstAndOverwritesTheOldestOnceFull) {
  StampedHistory<Stamped, 3> history;
  EXPECT_TRUE(history.empty());
  for (int k = 0; k < 5; ++k) history.push(0.1 * k).value = k;
  ASSERT_EQ(history.size(), 3);
  EXPECT_EQ(history.newest().value, 4);
  EXPECT_EQ(history.back(1).value, 3);
  EXPECT_EQ(history.back(2).value, 2);  // 0 and 1 overwritten
  EXPECT_DOUBLE_EQ(history.back(2).t, 0.2);
}

TEST(StampedHistory, FindsTheNewestRecordWithinTheToleranceOfATimeAndNoneOutsideIt) {
  StampedHistory<Stamped, 8> history;
  for (int k = 0; k < 4; ++k) history.push(0.05 * k).value = k;
  EXPECT_EQ(history.find(0.10, 0.025), 1);  // the record at 0.10, one before the newest
  EXPECT_EQ(history.find(0.11, 0.025), 1);  // within half a period
  EXPECT_EQ(history.find(0.125 + 0.02, 0.025), 0);
  EXPECT_EQ(history.find(0.20, 0.025), -1);   // after the newest
  EXPECT_EQ(history.find(-0.05, 0.025), -1);  // before the oldest
  EXPECT_EQ(history.find(0.075, 0.03), 1);    // two within reach: the newer one
}

TEST(StampedHistory, IsEmptyAfterClearAndRefillsFromTheStart) {
  StampedHistory<Stamped, 2> history;
  history.push(1.0).value = 1;
  history.push(2.0).value = 2;
  history.clear();
  EXPECT_TRUE(history.empty());
  EXPECT_EQ(history.find(2.0, 0.1), -1);
  history.push(3.0).value = 3;
  EXPECT_EQ(history.size(), 1);
  EXPECT_EQ(history.newest().value, 3);
}

}  // namespace
}  // namespace swerve
