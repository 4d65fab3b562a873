// ICR synchronisation: recovers the commanded centre, flags an inconsistent module, pairs per axle.
#include "swerve/kinematics/icr.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kinematics/test_layouts.hpp"

namespace swerve {
namespace {

TEST(Icr, ModuleAnglesOfARotationAboutAPointMeetAtThatPoint) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  for (const auto& [name, layout] : testing::layouts_2_to_8()) {
    SCOPED_TRACE(name);
    const Kinematics kinematics(layout);
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Vector2d centre(coordinate(rng), coordinate(rng));
      ModuleStates states;
      kinematics.inverse({0.0, 0.0, 1.3}, &states, centre);
      bool moving = true;
      for (const ModuleState& s : states) moving = moving && s.speed > 1e-3;
      if (!moving) continue;
      // Flip one module: headings count modulo pi.
      states[0] = ModuleState{-states[0].speed, wrap_angle(states[0].angle + kPi)};
      IcrEstimate icr;
      ASSERT_EQ(estimate_icr(kinematics, states, &icr), KinematicsStatus::kOk);
      if (layout.size() == 2) continue;  // two normals meet somewhere anyway; centre not unique if collinear
      ASSERT_FALSE(icr.at_infinity);
      EXPECT_NEAR((icr.center_body - centre).norm(), 0.0, 1e-8);
      EXPECT_NEAR(icr.residual, 0.0, 1e-10);
    }
  }
}

TEST(Icr, TranslationPutsTheCentreAtInfinityAlongTheNormal) {
  const Kinematics kinematics(ModuleLayout::rectangle(0.6, 0.4, 0.05));
  ModuleStates states;
  kinematics.inverse({0.6, 0.8, 0.0}, &states);
  IcrEstimate icr;
  ASSERT_EQ(estimate_icr(kinematics, states, &icr), KinematicsStatus::kOk);
  EXPECT_TRUE(icr.at_infinity);
  EXPECT_NEAR(std::abs(icr.direction_body.dot(Eigen::Vector2d(0.6, 0.8))), 1.0, 1e-12);
  EXPECT_NEAR(icr.residual, 0.0, 1e-12);
  EXPECT_TRUE(icr_of_twist({1.0, 0.0, 0.0}).at_infinity);
  const IcrEstimate spin = icr_of_twist({1.0, 0.0, 0.5});  // (-vy/w, vx/w)
  EXPECT_FALSE(spin.at_infinity);
  EXPECT_NEAR((spin.center_body - Eigen::Vector2d(0.0, 2.0)).norm(), 0.0, 1e-15);
}

TEST(Icr, AMisalignedModuleRaisesTheResidualAndStandsOut) {
  const Kinematics kinematics(ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05));
  ModuleStates states;
  kinematics.inverse({0.5, 0.0, 0.6}, &states);
  states[3].angle += 0.2;
  IcrEstimate icr;
  ASSERT_EQ(estimate_icr(kinematics, states, &icr), KinematicsStatus::kOk);
  EXPECT_GT(icr.residual, 0.01);
  int worst = 0;
  for (int i = 1; i < 6; ++i) {
    if (std::abs(icr.module_error[i]) > std::abs(icr.module_error[worst])) worst = i;
  }
  EXPECT_EQ(worst, 3);
}

TEST(Icr, AxlePairsAgreeOnConsistentCommandsAndTheFaultyAxleDisagrees) {
  const Kinematics kinematics(ModuleLayout::multi_axle(3, 0.5, 0.6, 0.05));
  ModuleStates states;
  kinematics.inverse({0.5, 0.0, 0.6}, &states);  // ICR at (0, 0.5/0.6)
  const Eigen::Vector2d centre(0.0, 0.5 / 0.6);
  IcrEstimate pair;
  ASSERT_EQ(pair_icr(kinematics, states, 0, 1, &pair), KinematicsStatus::kOk);
  EXPECT_NEAR((pair.center_body - centre).norm(), 0.0, 1e-9);
  ASSERT_EQ(pair_icr(kinematics, states, 4, 5, &pair), KinematicsStatus::kOk);
  EXPECT_NEAR((pair.center_body - centre).norm(), 0.0, 1e-9);
  states[5].angle += 0.1;
  ASSERT_EQ(pair_icr(kinematics, states, 4, 5, &pair), KinematicsStatus::kOk);
  EXPECT_GT((pair.center_body - centre).norm(), 0.05);
  ASSERT_EQ(pair_icr(kinematics, states, 0, 1, &pair), KinematicsStatus::kOk);
  EXPECT_NEAR((pair.center_body - centre).norm(), 0.0, 1e-9);
  EXPECT_EQ(pair_icr(kinematics, states, 1, 1, &pair), KinematicsStatus::kWrongModuleCount);
  EXPECT_EQ(estimate_icr(kinematics, ModuleStates(4), &pair), KinematicsStatus::kWrongModuleCount);
}

}  // namespace
}  // namespace swerve
