// core/smoothing.hpp: the clamp chosen on values passes the active side's derivative; the C1
// blends are exact outside their blend and continuous with their slope at its seams.
#include "swerve/core/smoothing.hpp"

#include <gtest/gtest.h>

#include <ceres/jet.h>

namespace swerve {
namespace {

using Jet = ceres::Jet<double, 1>;

TEST(Smoothing, TheBlendsAreExactOutsideTheirBlendAndC1AtItsSeams) {
  const double limit = 2.0, width = 0.5;
  EXPECT_EQ(soft_min(1.0, limit, width), 1.0);
  EXPECT_EQ(soft_min(3.0, limit, width), limit);
  for (const double seam : {limit - width, limit + width}) {
    const Jet below = soft_min(Jet(seam - 1e-9, 0), limit, width);
    const Jet above = soft_min(Jet(seam + 1e-9, 0), limit, width);
    EXPECT_NEAR(below.a, above.a, 1e-8) << "value at " << seam;
    EXPECT_NEAR(below.v[0], above.v[0], 1e-8) << "slope at " << seam;
  }
  EXPECT_EQ(soft_clamp(-5.0, -1.0, 1.0, 0.1), -1.0);
  EXPECT_EQ(soft_clamp(0.3, -1.0, 1.0, 0.1), 0.3);
  // soft_max mirrors soft_min: at the limit itself the blend sits width / 4 inside.
  EXPECT_NEAR(soft_max(0.0, 0.0, 0.2), 0.05, 1e-15);
  EXPECT_NEAR(soft_min(2.0, limit, width), limit - width / 4, 1e-15);
}

TEST(Smoothing, TheClampByValuePassesTheDerivativeOfTheActiveSide) {
  const Jet lower(-1.0, 0), upper(1.0, 0);
  Jet x(0.5, 0);
  EXPECT_EQ(clamp_by_value(x, Jet(-1.0), Jet(1.0)).v[0], 1.0);  // inside: x's own slope
  const Jet moving_bound(1.0 - 1e-3, 0);                        // a bound that moves with x
  x = Jet(2.0, 0);
  EXPECT_EQ(clamp_by_value(x, lower, moving_bound).a, 1.0 - 1e-3);
  EXPECT_EQ(clamp_by_value(x, lower, moving_bound).v[0], 1.0);  // the bound's slope
  EXPECT_EQ(clamp_by_value(x, Jet(-1.0), Jet(1.0)).v[0], 0.0);  // a constant bound: none
  EXPECT_EQ(clamp_by_value(-3.0, -1.0, 1.0), -1.0);
}

}  // namespace
}  // namespace swerve
