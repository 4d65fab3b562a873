// The clocks deadlines are kept on: the work clock advances by its cost per read and by advance()
// only, so a deadline on it passes after a known number of reads on every machine; threads that
// share one (SA's workers) lose no read.
#include "swerve/ocp/deadline.hpp"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace swerve {
namespace {

TEST(WorkClock, AdvancesByItsCostAtEveryReadAndByWhatIsAdded) {
  WorkClock clock(1e-3);
  const TimePoint first = clock.now();
  const TimePoint second = clock.now();
  EXPECT_EQ(second - first, to_duration(1e-3));
  clock.advance(to_duration(5e-3));
  EXPECT_EQ(clock.now() - second, to_duration(6e-3));
  EXPECT_EQ(clock.reads(), 3);
}

TEST(WorkClock, ADeadlineOnItPassesAfterAFixedNumberOfReads) {
  WorkClock clock(2e-3);
  const Deadline deadline = Deadline::in(to_duration(10e-3), clock);  // read 1: t = 2 ms, deadline 12 ms
  int reads_before_passing = 0;
  while (!deadline.passed()) ++reads_before_passing;  // reads 2.. at 4, 6, 8, 10, 12 ms
  EXPECT_EQ(reads_before_passing, 4);
  EXPECT_EQ(clock.reads(), 6);
}

TEST(WorkClock, ChargedModuleEvaluationsAdvanceItByTheirRateAndReadsByTheirs) {
  WorkClock clock(1e-3, 2e-6);
  const TimePoint first = clock.now();
  clock.charge(250.0);  // 250 evaluations at 2 us
  EXPECT_EQ(clock.now() - first, to_duration(1e-3 + 5e-4));
  clock.charge(0.0);
  clock.charge(-3.0);  // nothing to charge: time stands
  EXPECT_EQ(clock.now() - first, to_duration(2e-3 + 5e-4));
}

TEST(WorkClock, WithoutAnEvaluationRateChargesCostNothing) {
  WorkClock clock(1e-3);
  const TimePoint first = clock.now();
  clock.charge(1e6);
  EXPECT_EQ(clock.now() - first, to_duration(1e-3));
}

TEST(SteadyClock, IgnoresCharges) {
  // The wall clock already holds the time the work took; a charge must not move a deadline on it.
  const Deadline deadline = Deadline::in(to_duration(60.0));
  steady_clock().charge(1e12);
  EXPECT_FALSE(deadline.passed());
}

TEST(WorkClock, WithoutACostTimeStandsStill) {
  WorkClock clock;
  const TimePoint start = clock.now();
  for (int i = 0; i < 100; ++i) EXPECT_EQ(clock.now(), start);
  EXPECT_FALSE(Deadline(start + to_duration(1e-9), clock).passed());
}

TEST(WorkClock, ThreadsReadingOneClockLoseNoReadAndNoAdvance) {
  // SA's worker threads read the deadline's clock concurrently. With plain members the increments
  // raced (undefined behaviour; on two cores reads and time were lost).
  WorkClock clock(1e-6);
  constexpr int kThreads = 4;
  constexpr int kReadsEach = 100000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&clock] {
      for (int i = 0; i < kReadsEach; ++i) {
        clock.now();
        clock.advance(to_duration(1e-6));
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_EQ(clock.reads(), static_cast<long>(kThreads) * kReadsEach);
  // Every read and every advance moved it by one tick of 1 us; the final read adds one more.
  const long ticks = 2L * kThreads * kReadsEach + 1;
  EXPECT_EQ(clock.now().time_since_epoch(), ticks * to_duration(1e-6));
}

}  // namespace
}  // namespace swerve
