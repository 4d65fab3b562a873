// Wall-clock budgets in tests scale with the build: a sanitizer build runs ~10-20x slower, so the
// deadlines, budgets and elapsed-time limits that tests set are multiplied by this factor (1 in
// the optimised test build; SWERVE_TEST_TIME_SCALE from tests/CMakeLists.txt otherwise).
#pragma once

#ifndef SWERVE_TEST_TIME_SCALE
#define SWERVE_TEST_TIME_SCALE 1
#endif

namespace swerve::testing {

inline constexpr double kTimeScale = SWERVE_TEST_TIME_SCALE;

}  // namespace swerve::testing
