// TrackingTube: the tolerance per stage, widened to the baseline's own predicted error, and the
// rule that a plan beyond it by more than a quarter of the tolerance is not sent.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "support/config_errors.hpp"
#include "support/linear_models.hpp"
#include "swerve/control/tracking_tube.hpp"

namespace swerve {
namespace {

constexpr int kHorizon = 5;

TrackingTolerance tolerance() {
  TrackingTolerance t;
  t.position = 0.05;
  t.heading = 0.02;
  return t;
}

// The linear-quadratic problem of the solver tests (a reference moving (0.1 k, 0.05 k) m and
// 0.01 k rad by stage k), its model's scratch, and a tube of tolerance() on it.
struct TubeOnAProblem {
  testing::DoubleIntegratorModel model;
  OcpProblem problem = testing::make_lq_problem(model, kHorizon);
  std::unique_ptr<PredictionData> data = model.create_data();
  TrackingTube tube{tolerance(), problem};
};

TEST(TrackingTube, WithoutABaselinePlanEveryStageIsTheTolerance) {
  TubeOnAProblem t;
  t.tube.set(t.problem, *t.data, nullptr);
  for (int k = 0; k < kHorizon; ++k) {
    EXPECT_EQ(t.problem.tube()(0, k), 0.05);
    EXPECT_EQ(t.problem.tube()(1, k), 0.02);
  }
}

TEST(TrackingTube, WidensToTheBaselinesOwnPredictedErrorWhereItIsLarger) {
  // Standing still at the origin (zero accelerations from rest) against a reference that moves
  // (0.1 k, 0.05 k) m and 0.01 k rad by stage k: the error is 0.1118 k m and 0.01 k rad.
  TubeOnAProblem t;
  const Eigen::MatrixXd standing = Eigen::MatrixXd::Zero(3, kHorizon);
  t.tube.set(t.problem, *t.data, &standing);
  for (int k = 1; k <= kHorizon; ++k) {
    EXPECT_NEAR(t.problem.tube()(0, k - 1), std::max(0.05, k * std::hypot(0.1, 0.05)), 1e-12) << "stage " << k;
    EXPECT_NEAR(t.problem.tube()(1, k - 1), std::max(0.02, 0.01 * k), 1e-12) << "stage " << k;
  }
}

TEST(TrackingTube, APlanBeyondItByMoreThanAQuarterOfTheToleranceHasLeftIt) {
  TubeOnAProblem t;
  t.tube.set(t.problem, *t.data, nullptr);
  Eigen::MatrixXd on_reference = Eigen::MatrixXd::Zero(6, kHorizon + 1);
  for (int k = 1; k <= kHorizon; ++k) on_reference.col(k).head<3>() << 0.1 * k, 0.05 * k, 0.01 * k;
  EXPECT_FALSE(t.tube.left(t.problem, on_reference));
  Eigen::MatrixXd within_slack = on_reference;
  within_slack(0, 3) += 0.05 + 0.2 * 0.05;  // the tolerance and a fifth of it
  EXPECT_FALSE(t.tube.left(t.problem, within_slack));
  Eigen::MatrixXd beyond = on_reference;
  beyond(2, 4) += 0.02 + 0.3 * 0.02;  // the heading tolerance and 30 % of it
  EXPECT_TRUE(t.tube.left(t.problem, beyond));
}

TEST(TrackingTolerance, RefusesANegativeBoundNamingTheField) {
  TrackingTolerance t = tolerance();
  t.heading = -0.1;
  EXPECT_EQ(testing::config_error_of([&] { t.validate(); }), "TrackingTolerance.heading = -0.1: must be finite and > 0 (rad)");
}

}  // namespace
}  // namespace swerve
