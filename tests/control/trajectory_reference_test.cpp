// TrajectoryReference, the planner-fed reference: the same interpolation as SampledReference, a new
// trajectory taken up only at a cycle's start, refused trajectories naming the sample and leaving
// the active one in place, staleness, and a planner thread publishing while a control thread
// samples (every cycle's window from one trajectory, never a torn one).
#include "swerve/control/reference.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "swerve/core/config_error.hpp"

namespace swerve {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// k samples of a circle of radius 2 at 1 m/s from t0, heading along the path, 4 columns.
Eigen::MatrixXd circle(int k, double t0, double dt = 0.1) {
  Eigen::MatrixXd rows(k, 4);
  for (int i = 0; i < k; ++i) {
    const double t = t0 + i * dt, angle = 0.5 * (t - t0);
    rows.row(i) << t, 2.0 * std::sin(angle), 2.0 * (1.0 - std::cos(angle)), wrap_angle(angle);
  }
  return rows;
}

std::vector<std::vector<double>> as_rows(const Eigen::MatrixXd& m) {
  std::vector<std::vector<double>> rows(static_cast<std::size_t>(m.rows()));
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) rows[static_cast<std::size_t>(i)].push_back(m(i, c));
  }
  return rows;
}

TEST(TrajectoryReference, SamplesAPublishedTrajectoryExactlyAsTheSampledReferenceDoesOnItsOwnClock) {
  const Eigen::MatrixXd rows = circle(40, 5.0);
  TrajectoryReference reference(64);
  ASSERT_TRUE(reference.publish(rows).accepted());
  reference.begin_cycle();
  const SampledReference recorded(as_rows(rows));  // samples relative to its first time
  for (const double t : {4.0, 5.0, 5.03, 6.47, 8.9, 8.95, 12.0}) {
    const ReferenceSample a = reference.sample(t), b = recorded.sample(t - 5.0);
    EXPECT_EQ(a.pose_world, b.pose_world) << "t = " << t;
    EXPECT_EQ(a.twist_body, b.twist_body) << "t = " << t;
  }
  // On the path the twist is the circle's: 1 m/s forward, 0.5 rad/s.
  const ReferenceSample mid = reference.sample(6.5);
  EXPECT_NEAR(mid.twist_body.x(), 1.0, 1e-3);
  EXPECT_NEAR(mid.twist_body.y(), 0.0, 1e-3);
  EXPECT_NEAR(mid.twist_body.z(), 0.5, 1e-3);
  EXPECT_DOUBLE_EQ(reference.duration(), 5.0 + 39 * 0.1);
}

TEST(TrajectoryReference, AGivenTwistIsInterpolatedInsteadOfDerived) {
  Eigen::MatrixXd rows(3, 7);
  rows << 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,  //
      1.0, 1.0, 0.0, 0.0, 2.0, 0.2, 0.0,       //
      2.0, 3.0, 0.0, 0.0, 3.0, 0.0, 0.0;
  TrajectoryReference reference(8);
  ASSERT_TRUE(reference.publish(rows).accepted());
  reference.begin_cycle();
  EXPECT_NEAR(reference.sample(0.5).twist_body.x(), 1.5, 1e-12);
  EXPECT_NEAR(reference.sample(0.5).twist_body.y(), 0.1, 1e-12);
}

TEST(TrajectoryReference, ANewTrajectoryIsTakenUpOnlyAtTheStartOfACycle) {
  TrajectoryReference reference(16);
  EXPECT_STREQ(reference.unusable(0.0), "reference: no trajectory published yet");
  reference.begin_cycle();
  EXPECT_NE(reference.unusable(0.0), nullptr);
  ASSERT_TRUE(reference.publish(circle(10, 0.0)).accepted());
  EXPECT_NE(reference.unusable(0.0), nullptr);  // published, not yet taken up
  EXPECT_EQ(reference.version(), 0);
  reference.begin_cycle();
  EXPECT_EQ(reference.unusable(0.0), nullptr);
  EXPECT_EQ(reference.version(), 1);
  const ReferenceSample before = reference.sample(0.35);
  Eigen::MatrixXd shifted = circle(10, 0.0);
  shifted.col(2).array() += 1.0;
  ASSERT_TRUE(reference.publish(shifted).accepted());
  EXPECT_EQ(reference.sample(0.35).pose_world, before.pose_world);  // the cycle's window stays whole
  reference.begin_cycle();
  EXPECT_NEAR(reference.sample(0.35).pose_world.y(), before.pose_world.y() + 1.0, 1e-12);
  EXPECT_EQ(reference.version(), 2);
  reference.begin_cycle();  // nothing new: nothing changes
  EXPECT_EQ(reference.version(), 2);
}

TEST(TrajectoryReference, RefusesABadTrajectoryNamingTheSampleAndKeepsTheActiveOne) {
  TrajectoryReference reference(16);
  ASSERT_TRUE(reference.publish(circle(10, 0.0)).accepted());
  reference.begin_cycle();
  const ReferenceSample active = reference.sample(0.42);

  EXPECT_EQ(reference.publish(circle(1, 0.0)).status, TrajectoryStatus::kTooFewSamples);
  EXPECT_EQ(reference.publish(circle(17, 0.0)).status, TrajectoryStatus::kTooManySamples);
  EXPECT_EQ(reference.publish(Eigen::MatrixXd::Zero(5, 5)).status, TrajectoryStatus::kWrongWidth);
  Eigen::MatrixXd nan = circle(10, 0.0);
  nan(2, 1) = kNaN;
  const TrajectoryCheck not_finite = reference.publish(nan);
  EXPECT_EQ(not_finite.status, TrajectoryStatus::kNonFinite);
  EXPECT_EQ(not_finite.describe(), "sample 2 column 1: a value is NaN or infinite");
  Eigen::MatrixXd backwards = circle(10, 0.0);
  backwards(3, 0) = backwards(2, 0);
  const TrajectoryCheck repeated = reference.publish(backwards);
  EXPECT_EQ(repeated.status, TrajectoryStatus::kTimeNotIncreasing);
  EXPECT_EQ(repeated.sample, 3);
  EXPECT_EQ(repeated.describe(), "sample 3 column 0: t must be greater than the previous sample's");
  Eigen::MatrixXd infinite = circle(10, 0.0);
  infinite(7, 3) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(reference.publish(infinite).sample, 7);

  reference.begin_cycle();
  EXPECT_EQ(reference.version(), 1);
  EXPECT_EQ(reference.sample(0.42).pose_world, active.pose_world);
}

TEST(TrajectoryReference, ATrajectoryOlderThanMaxAgeIsStale) {
  TrajectoryReference reference(16, 0.5);
  ASSERT_TRUE(reference.publish(circle(10, 2.0)).accepted());
  reference.begin_cycle();
  EXPECT_EQ(reference.unusable(2.0), nullptr);
  EXPECT_EQ(reference.unusable(2.5), nullptr);
  EXPECT_STREQ(reference.unusable(2.51),
               "reference: the trajectory is stale (its first sample is older than max_age)");
  ASSERT_TRUE(reference.publish(circle(10, 2.4)).accepted());
  reference.begin_cycle();
  EXPECT_EQ(reference.unusable(2.51), nullptr);
}

TEST(TrajectoryReference, RejectsABadCapacityOrMaxAgeNamingTheField) {
  const auto message_of = [](int capacity, double max_age) {
    try {
      TrajectoryReference reference(capacity, max_age);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(message_of(1, 1.0), "TrajectoryReference.capacity = 1: must be >= 2");
  EXPECT_NE(message_of(8, 0.0).find("TrajectoryReference.max_age = 0"), std::string::npos);
  EXPECT_NE(message_of(8, kNaN).find("TrajectoryReference.max_age = nan"), std::string::npos);
  EXPECT_EQ(message_of(8, std::numeric_limits<double>::infinity()), "(accepted)");
}

TEST(TrajectoryReference, APlannerThreadPublishingWhileTheControlThreadSamplesNeverTearsAWindow) {
  // Trajectory number j is the straight line y = j (every sample), x = t. Each control cycle takes
  // up the newest one and samples a 20-step window: every pose in it must have the same integer y,
  // and the versions must only increase. Iteration counts, not wall-clock time, bound the test.
  constexpr int kSamples = 50;
  constexpr int kTrajectories = 3000;
  TrajectoryReference reference(kSamples);
  std::atomic<bool> done{false};
  std::thread planner([&] {
    Eigen::MatrixXd rows(kSamples, 4);
    for (int j = 1; j <= kTrajectories; ++j) {
      for (int i = 0; i < kSamples; ++i) rows.row(i) << 0.1 * i, 0.1 * i, static_cast<double>(j), 0.0;
      if (!reference.publish(rows).accepted()) ADD_FAILURE() << "trajectory " << j << " refused";
    }
    done.store(true);
  });
  long cycles = 0, torn = 0, backwards = 0, previous_version = 0;
  double previous_y = 0.0;
  while (!done.load() || cycles < 100) {
    reference.begin_cycle();
    ++cycles;
    if (reference.unusable(0.0) != nullptr) continue;
    const double y = reference.sample(0.0).pose_world.y();
    // Torn: a pose of another trajectory (an integer away). Not bit equality: between samples the
    // spline's interpolation of a constant returns it only to rounding where the compiler
    // contracts it into fused multiply-adds (aarch64 does: 906 "tears" of 1 ulp under qemu).
    for (int k = 1; k <= 20; ++k) {
      if (std::abs(reference.sample(0.05 * k).pose_world.y() - y) > 0.25) ++torn;
    }
    if (y != std::round(y) || y < previous_y || reference.version() < previous_version) ++backwards;
    previous_y = y;
    previous_version = reference.version();
  }
  planner.join();
  reference.begin_cycle();
  EXPECT_EQ(torn, 0);
  EXPECT_EQ(backwards, 0);
  EXPECT_EQ(reference.version(), kTrajectories);
  EXPECT_EQ(reference.sample(1.0).pose_world.y(), kTrajectories);
}

}  // namespace
}  // namespace swerve
